// Analytic distance maps for tests of the force model: D(p) = a . p + b at every voxel centre of a
// 1 mm grid of `dims` (voxel (i, j, k) at (i, j, k) mm), clamped to +-band as a map's band is.
#pragma once

#include <algorithm>
#include <cstdint>

#include "base/vec.hpp"
#include "base/volume.hpp"

namespace palp::test {

inline DistanceMap linear_map(const Index3& dims, Vec3d a, double b, double band = 1e9) {
  Grid g;
  g.dims = dims;
  g.spacing = {1.0, 1.0, 1.0};
  DistanceMap m(g, 0.0f);
  for (std::int64_t k = 0; k < dims[2]; ++k)
    for (std::int64_t j = 0; j < dims[1]; ++j)
      for (std::int64_t i = 0; i < dims[0]; ++i) {
        const Vec3d p{static_cast<double>(i), static_cast<double>(j), static_cast<double>(k)};
        m.at(i, j, k) = static_cast<float>(std::clamp(dot(a, p) + b, -band, band));
      }
  return m;
}

}  // namespace palp::test
