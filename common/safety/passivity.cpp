// Passivity observer and controller: see passivity.hpp.
#include "safety/passivity.hpp"

#include <algorithm>
#include <cmath>

namespace palp {

PassivityOutput passivity_control(PassivityState state, const Vec3d& force, const Vec3d& velocity,
                                  double dt, double max_damping_N_s_per_mm) {
  PassivityOutput out;
  out.force = force;
  const double t = std::isfinite(dt) ? std::clamp(dt, 0.0, 0.01) : 0.0;
  if (!is_finite(force) || !is_finite(velocity) || !std::isfinite(state.energy_mJ)) {
    out.state = PassivityState{};  // nothing sensible to observe: start over
    return out;
  }
  // observer: energy into the environment this tick
  state.energy_mJ += -dot(force, velocity) * t;
  const double v2 = dot(velocity, velocity);
  if (state.energy_mJ < 0.0 && v2 > 0.0 && t > 0.0 && max_damping_N_s_per_mm > 0.0) {
    // controller: the damping that dissipates the deficit this tick, within the device's
    const double alpha =
        std::min(-state.energy_mJ / (v2 * t), std::max(0.0, max_damping_N_s_per_mm));
    out.force = force - velocity * alpha;
    out.damping_N_s_per_mm = alpha;
    out.dissipated_mJ = alpha * v2 * t;
    state.energy_mJ += out.dissipated_mJ;
  }
  out.state = state;
  return out;
}

}  // namespace palp
