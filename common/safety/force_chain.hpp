// The chain between the force model and a device, every tick, as one pure step the real-time
// loop and the closed-loop studies share (so a study measures exactly what a hand gets):
//
//   model force at the virtual tool ─► virtual coupling (spring-damper to the device, at most the
//   device's stable stiffness: virtual_coupling.hpp) ─► clamp ─► engagement gain (from the
//   model's force) ─► passivity controller (only once engaged and while a force is rendered;
//   filtered velocity; never pulls: a damper that would reverse the force lets go instead) ─► step
//   bound on what was written last ─► clamp ─► device
//
// The passivity observer watches the port: at each tick, the force applied over the tick just ended
// against the device's travel over it (passivity.hpp), whatever the force was and whichever stage
// shaped it. That force was written the tick before, or d ticks earlier under a transport delay of
// d ticks (DeviceProfile::transport_delay_s, rounded to ticks; the coupling's damping widens with
// it too: virtual_coupling.hpp).
//
// A known active force (issue 39: the arteries' pulse, State::f_pulse, part of the model's force)
// is carried beside the total. It does not go through the coupling or the stiffness limiter:
// those exist to hide the model's stiffness from the device, a force driven by the clock has none,
// and through them it would be lost in the coupling's series spring (K_c / (K_c + K) of it at a
// held device) and its rise and fall read as stiffness by the coupling's secant. It joins the
// passive part's output before the first clamp, so every limit still applies to the total:
//
//   passive = model - active ─► coupling (or limiter) ─► + active ─► clamp ─► engagement ─►
//   passivity controller ─► step bound ─► clamp ─► device
//
// and its part of the written force is tracked through each stage that scales or steps the total
// (the clamps' factor, the engagement gain, the step bound's fraction of the way from the last
// written force, whose own active part it remembers; a controller that lets go writes none of
// it). The observer leaves that part's work out as the known input's (passivity.hpp). With no
// active force the chain is the one before, bit for bit.
//
// With the coupling on, the model is to be evaluated at force_chain_tool() (the virtual tool),
// not at the device. With it off (the chain before the coupling, kept for the studies), the
// first stage is the stiffness limiter instead: clamp, stiffness and rate limits on the
// limiter's own previous output (apply_device_limits), with the model at the device.
//
// The state is a value the caller keeps; reset_force_chain() after a fault or a model change
// (zero written, engagement and observer restart). Nothing else resets the observer.
#pragma once

#include <array>
#include <cstdint>
#include <optional>

#include "base/vec.hpp"
#include "safety/engagement.hpp"
#include "safety/passivity.hpp"
#include "safety/safety.hpp"
#include "safety/virtual_coupling.hpp"

namespace palp {

struct ForceChainConfig {
  std::optional<EngageParams> engage;  // unset: no engagement
  bool passivity = false;              // the passivity observer/controller
  double velocity_filter_s = 0.005;    // time constant of the velocity the controller damps
  // The virtual coupling (the default in palpd); false: the stiffness limiter instead.
  bool coupling = true;
};

// The longest transport delay, in ticks, the observer lines up (2 ms at 10 kHz is 20).
inline constexpr int kMaxDelayTicks = 32;

struct ForceChainState {
  Vec3d limited_prev{};  // the limiter's own last output (its step limits follow it)
  Vec3d written_prev{};  // what the device was written last tick
  Vec3d active_prev{};   // the known active force's part of it
  // what it was written before that: [i] i + 2 ticks ago (the force still in flight under a
  // transport delay, which the observer pairs with the travel it is applied over)
  std::array<Vec3d, kMaxDelayTicks> written_earlier{};
  std::array<Vec3d, kMaxDelayTicks> active_earlier{};  // and their active parts
  Vec3d position_prev{};
  bool have_prev = false;
  Vec3d velocity{};  // filtered device velocity, mm/s
  Engagement engagement;
  PassivityState passivity;
  CouplingState coupling;
};

struct ForceChainOutput {
  Vec3d force{}, torque{};
  std::uint32_t status = kSafetyOk;
  double damping_N_s_per_mm = 0.0;  // the passivity controller's, this tick
  double dissipated_mJ = 0.0;       // what the damper is to dissipate (the observer sees the rest)
  double coupling_stiffness_N_per_mm = 0.0;  // the coupling's K_c this tick (0: off)
  double port_energy_mJ = 0.0;  // the observer's energy at the port, through last tick's force
  Vec3d active{};  // the known active force's part of `force` (what of it the limits let through)
};

// Where the model is to be evaluated this tick (device frame, mm): the virtual tool when the
// coupling is on and engaged, else the device itself.
Vec3d force_chain_tool(const ForceChainState& state, const ForceChainConfig& config,
                       const Vec3d& device_position);

// One tick: `limits` (the profile, already lowered to the device's declarations), the model's
// device force, torque and stiffness (State::stiffness, N/mm) at force_chain_tool(), the device
// position (mm, device frame), `dt` (s), and `active_force` (N, device frame): the part of
// `model_force` that is a known active input (State::f_pulse of the same tick; 0: none). A
// non-finite active force is handled as a non-finite model force is (the first stage renders
// nothing, the step bound brings the written force down to it) and flagged kSafetyNonFinite.
ForceChainOutput run_force_chain(ForceChainState& state, const ForceChainConfig& config,
                                 const DeviceProfile& limits, const Vec3d& model_force,
                                 const Vec3d& model_torque, double model_stiffness,
                                 const Vec3d& position, double dt, const Vec3d& active_force = {});

// After a fault, a replug, a model change or a pause: zero written, engagement and observer
// restart, the next position starts the velocity afresh.
void reset_force_chain(ForceChainState& state);

}  // namespace palp
