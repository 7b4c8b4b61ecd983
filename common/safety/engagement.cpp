// Force engagement after every reset: see engagement.hpp.
#include "safety/engagement.hpp"

#include <algorithm>
#include <cmath>

#include "base/errors.hpp"

namespace palp {

Engagement engage(Engagement state, double commanded_N, double dt, const EngageParams& params) {
  if (state.waiting) {
    if (std::isfinite(commanded_N) && commanded_N < params.threshold_N) state.waiting = false;
    state.gain = 0.0;
    return state;
  }
  const double step = std::isfinite(dt) ? std::clamp(dt, 0.0, 0.01) : 0.0;
  state.gain = params.ramp_s > 0.0 ? std::min(1.0, state.gain + step / params.ramp_s) : 1.0;
  return state;
}

void validate(const EngageParams& params) {
  if (!(params.threshold_N > 0.0 && params.threshold_N <= 5.0))
    throw UsageError("engagement threshold must be in (0, 5] N");
  if (!(params.ramp_s >= 0.0 && params.ramp_s <= 10.0))
    throw UsageError("engagement ramp must be 0..10 s");
}

}  // namespace palp
