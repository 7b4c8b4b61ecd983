// A CT of nested balls drawn with partial volume: each voxel's HU is the blend of the materials
// covering it, counted on sub x sub x sub points (as a scanner's voxel averages what it holds).
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "base/vec.hpp"
#include "base/volume.hpp"

namespace palp::testing {

struct Ball {
  Vec3d centre;   // mm from voxel (0,0,0)'s centre
  double radius;  // mm
  double hu;      // inside (a later ball is drawn over an earlier one)
};

// `background_hu` where no ball covers a point; HU rounded to the nearest integer.
inline CtVolume partial_volume_balls(const Grid& grid, const std::vector<Ball>& balls,
                                     double background_hu, int sub = 6) {
  CtVolume ct(grid, 0, "partial-volume CT");
  const Vec3& h = grid.spacing;
  for (std::int64_t k = 0; k < grid.dims[2]; ++k)
    for (std::int64_t j = 0; j < grid.dims[1]; ++j)
      for (std::int64_t i = 0; i < grid.dims[0]; ++i) {
        double sum = 0.0;
        for (int a = 0; a < sub; ++a)
          for (int b = 0; b < sub; ++b)
            for (int e = 0; e < sub; ++e) {
              const Vec3d x{(i + (a + 0.5) / sub - 0.5) * h[0], (j + (b + 0.5) / sub - 0.5) * h[1],
                            (k + (e + 0.5) / sub - 0.5) * h[2]};
              double hu = background_hu;
              for (const Ball& ball : balls)
                if (norm(x - ball.centre) <= ball.radius) hu = ball.hu;
              sum += hu;
            }
        ct.at(i, j, k) = static_cast<std::int16_t>(std::lround(sum / (sub * sub * sub)));
      }
  return ct;
}

}  // namespace palp::testing
