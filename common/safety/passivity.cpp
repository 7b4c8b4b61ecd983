// Passivity observer and controller: see passivity.hpp.
#include "safety/passivity.hpp"

#include <algorithm>
#include <cmath>

namespace palp {

PassivityState observe_port(PassivityState state, const Vec3d& written_prev, const Vec3d& travel_mm,
                            const Vec3d& active_prev) {
  if (!std::isfinite(state.energy_mJ)) state.energy_mJ = 0.0;
  if (!is_finite(written_prev) || !is_finite(travel_mm) || !is_finite(active_prev)) return state;
  // the work the written force's passive part did on the device came out of the rendered
  // environment; the active part's is the known input's (x - 0 is x: bit for bit without one)
  state.energy_mJ -= dot(written_prev - active_prev, travel_mm);
  return state;
}

PassivityOutput passivity_control(const PassivityState& state, const Vec3d& force,
                                  const Vec3d& velocity, double dt, double max_damping_N_s_per_mm) {
  PassivityOutput out;
  out.force = force;
  const double t = std::isfinite(dt) ? std::clamp(dt, 0.0, 0.01) : 0.0;
  if (!is_finite(force) || !is_finite(velocity) || !std::isfinite(state.energy_mJ)) return out;
  const double v2 = dot(velocity, velocity);
  if (state.energy_mJ < 0.0 && v2 > 0.0 && t > 0.0 && max_damping_N_s_per_mm > 0.0) {
    // the damping that would dissipate the deficit over this tick, within the device's
    const double alpha = std::min(-state.energy_mJ / (v2 * t), max_damping_N_s_per_mm);
    out.force = force - velocity * alpha;
    out.damping_N_s_per_mm = alpha;
    out.dissipated_mJ = alpha * v2 * t;
  }
  return out;
}

}  // namespace palp
