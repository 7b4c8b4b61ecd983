// A time-domain passivity observer and controller at the device port (Hannaford & Ryu 2002), the
// backstop behind the limits: it watches the energy the rendered environment exchanges with the
// hand and, when the environment has put out more than it took in (sampling and the limiter can
// make it do so), dissipates the excess with an adaptive damper that opposes the device's motion.
//
//   observer    E += -F · v · dt   (mJ = N·mm; F the force the device pushes the hand with, v the
//                                   device's velocity: pushing into the skin stores energy, being
//                                   pushed out returns it; a passive rendering keeps E >= 0)
//   controller  E < 0: α = min(-E / (|v|² dt), α_max); F' = F - α v; E += α |v|² dt
//
// Pure: the state (the observed energy) is a value the loop keeps and resets with engagement.
#pragma once

#include "base/vec.hpp"

namespace palp {

struct PassivityState {
  double energy_mJ = 0.0;
};

struct PassivityOutput {
  Vec3d force{};
  double damping_N_s_per_mm = 0.0;  // α applied this tick (0: the controller was idle)
  double dissipated_mJ = 0.0;
  PassivityState state;
};

// One tick: `force` (N) about to be written, `velocity` (mm/s) of the device, `dt` (s, taken in
// [0, 0.01]), `max_damping` (N·s/mm, the device's largest renderable damping; 0: observe only).
PassivityOutput passivity_control(PassivityState state, const Vec3d& force, const Vec3d& velocity,
                                  double dt, double max_damping_N_s_per_mm);

}  // namespace palp
