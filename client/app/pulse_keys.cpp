// The controller's pulse keys: see pulse_keys.hpp.
#include "app/pulse_keys.hpp"

#include <algorithm>
#include <cmath>

namespace palp::view {

std::optional<double> pulse_request(double now_bpm, const PulseKeys& keys, double& last_on_bpm) {
  const double now = std::isfinite(now_bpm) ? std::clamp(now_bpm, 0.0, kMaxPulseBpm) : 0.0;
  if (now > 0) last_on_bpm = now;
  double want = now;
  if (keys.toggle) want = now > 0 ? 0.0 : (last_on_bpm > 0 ? last_on_bpm : kRestingPulseBpm);
  want = std::clamp(want + kPulseStepBpm * keys.steps, 0.0, kMaxPulseBpm);
  if (want == now) return std::nullopt;
  return want;
}

}  // namespace palp::view
