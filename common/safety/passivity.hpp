// A time-domain passivity observer and controller at the device port (Hannaford & Ryu 2002), the
// backstop behind the limits: it watches the energy the rendered environment exchanges with the
// hand and, when the environment has put out more than it took in (sampling, delay and the
// limiter can make it do so), dissipates the excess with an adaptive damper that opposes the
// device's motion.
//
// The port is where the force meets the device: the observer sums the force actually written (after
// the step bound and the clamp, zeroed or not) against the device's travel while that force was
// held. With the force written at tick n-1 held over [n-1, n] and x(n) the position read at tick n:
//
//   observer    E(n) = E(n-1) - (f_w(n-1) - f_a(n-1)) · (x(n) - x(n-1))      (mJ = N·mm)
//
// E is the energy the hand has put into the rendered environment since the chain's last reset:
// pushing into the skin stores energy (f_w points out, x moves in: E grows), being pushed out
// returns it. A passive rendering keeps E >= 0. (x(n) - x(n-1) is v(n) T with v the backward
// difference, Hannaford and Ryu's f(k) v(k) ΔT with the force paired to the interval it was held.)
//
// A known active input (issue 39: an artery's pulse, State::f_pulse). Some of the model's force is
// meant to put energy into the hand: a force source driven by the model's clock, not by where the
// hand is. Write the written force as the sum of what the passive laws made of the motion and what
// the source made of the clock, f_w = f_p + f_a, f_a the source's part as written (the force chain
// carries it through every stage that scales or steps the total: force_chain.hpp). Over a tick the
// hand receives f_w · Δx = f_p · Δx + f_a · Δx. Passivity is a claim about the environment, not
// about the heart: a passive environment with a supply u obeys stored(n) <= stored(0) + (work the
// hand did on it) + (energy u supplied), and the energy the source supplied to the hand over the
// tick is f_a · Δx, known exactly. Moving it to the left leaves the passive part's balance,
//
//   E(n) = E(n-1) - f_w(n-1) · Δx(n) + f_a(n-1) · Δx(n) = -Σ f_p · Δx  >= 0 for a passive f_p,
//
// which is the observer above. Two consequences, both tested (passivity_test, force_chain_test):
//  - a pure source (f_p = 0) leaves E at exactly 0 however the hand moves, so the controller never
//    mistakes the beat's work for a deficit and never damps it away (with f_a left in E, a hand
//    that yields to the pulse takes ∮ f_a dx > 0 each beat, E falls by that per beat and the
//    damper grows until the pulse is gone);
//  - E is the passive part's own balance, so a passive part that gives out energy (a sampled,
//    delayed or negatively damped spring) drives E below 0 exactly as it would without the
//    source; the source can neither fill the deficit nor deepen it.
// f_a must be the part of the *written* force that came from the source, not the commanded one: a
// clamp, an engagement ramp or a step bound that cut the total cut the source's part too, and
// crediting the commanded source for work its clipped remainder did not do would hide a deficit.
// With f_a = 0 the observer is Hannaford and Ryu's, bit for bit.
//
//   controller  E(n) < 0: α = min(-E(n) / (|v|² T), α_max); F' = F - α v
//
// The controller does not credit itself: what its damper dissipates reaches E only through the
// force written next, observed at the next tick. E is never reset but by the chain's reset (a
// fault, a model change, re-engagement): a tick with no force adds nothing, it does not forgive
// a deficit. Its damper belongs to the passive part (it is a damper on the device's motion).
//
// Pure: the state (the observed energy) is a value the loop keeps and resets with the chain.
#pragma once

#include "base/vec.hpp"

namespace palp {

struct PassivityState {
  double energy_mJ = 0.0;
};

// The observer, one tick: `written_prev` (N) the force written at the previous tick, held over the
// period just ended, `travel_mm` the device's travel over it (x(n) - x(n-1), mm), `active_prev`
// (N) the known active input's part of `written_prev` (0: none). A non-finite force, active part
// or travel adds nothing; a non-finite energy restarts at 0.
PassivityState observe_port(PassivityState state, const Vec3d& written_prev, const Vec3d& travel_mm,
                            const Vec3d& active_prev = {});

struct PassivityOutput {
  Vec3d force{};
  double damping_N_s_per_mm = 0.0;  // α applied this tick (0: the controller was idle)
  double dissipated_mJ = 0.0;       // α |v|² T: what the damper is to dissipate, if written
};

// The controller, one tick: `force` (N) about to be written, `velocity` (mm/s) of the device,
// `dt` (s, taken in [0, 0.01]), `max_damping` (N·s/mm, the device's largest renderable damping;
// 0: idle). The state is read, not changed.
PassivityOutput passivity_control(const PassivityState& state, const Vec3d& force,
                                  const Vec3d& velocity, double dt, double max_damping_N_s_per_mm);

}  // namespace palp
