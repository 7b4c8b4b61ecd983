// The sub-voxel maps' values are rounded to 1/1024 mm (0.0005 mm at most, far below any surface's
// own uncertainty; the low mantissa bits become zeros that gzip packs well).
#pragma once

#include <cmath>

namespace palp {

inline constexpr float kMapSteps = 1024.0f;

// std::nearbyint(y) in the default rounding mode (to nearest, ties to even), sign of zero
// included, without a libm call, so loops over whole maps vectorize: below 2^23 adding and
// subtracting 2^23 rounds |y| to an integer; from 2^23 on every float is one.
inline float nearest_integer(float y) {
  constexpr float kTwo23 = 8388608.0f;
  const float a = std::abs(y);
  const float rounded = (a + kTwo23) - kTwo23;
  return std::copysign(a < kTwo23 ? rounded : a, y);
}

// mm rounded to the nearest 1/1024 mm.
inline float round_to_map_step(float mm) {
  return nearest_integer(mm * kMapSteps) / kMapSteps;
}

}  // namespace palp
