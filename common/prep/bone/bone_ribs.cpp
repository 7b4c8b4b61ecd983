// Ribs whose peak the scan lowered under the seed level (see bone_ribs.hpp).
#include "prep/bone/bone_ribs.hpp"

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "prep/bone/bone_islands.hpp"
#include "prep/segment/segmentation_shared.hpp"

namespace palp::segmentation {

std::vector<std::uint8_t> unseeded_ribs(const CtVolume& ct, const Mask& body,
                                        const PatientAxes& axes, const RunTable& runs,
                                        const RunLabels& labels,
                                        const std::vector<std::uint8_t>& seeded,
                                        const SegmentationParams& params) {
  const std::size_t count = labels.voxels.size();
  std::vector<std::uint8_t> rib(count, 0);
  const double depth = params.bone_rib_depth_mm;
  if (depth <= 0.0) return rib;
  const Grid& g = body.grid;
  const double ml = voxel_ml(g);
  // By shape first (one pass over the runs): unseeded rods of rib width, large enough to stay.
  const std::vector<IslandShape> shapes = island_shapes(g, runs, labels);
  bool any = false;
  for (std::size_t c = 0; c < count; ++c) {
    if (seeded[c] || static_cast<double>(labels.voxels[c]) * ml < params.min_bone_island_ml)
      continue;
    const IslandShape& s = shapes[c];
    const double width = 2.0 * std::sqrt(3.0) * s.sd[1];
    if (s.sd[0] >= kBoneIslandElongation * s.sd[1] && width >= kBoneRibMinWidthMm &&
        width <= kBoneRibMaxWidthMm)
      rib[c] = 1, any = true;
  }
  if (!any) return rib;
  // Then where they lie, voxel by voxel, for those rods only. The eight directions of the slice
  // plane: steps along its two axes.
  const int a1 = axes.lateral, a2 = axes.posterior;
  const std::int64_t stride[3] = {1, g.dims[0], g.dims[0] * g.dims[1]};
  struct Direction {
    std::int64_t d1, d2, step;  // index steps, linear step
    double mm;                  // length of one step
  };
  std::vector<Direction> dirs;
  for (std::int64_t d1 = -1; d1 <= 1; ++d1)
    for (std::int64_t d2 = -1; d2 <= 1; ++d2)
      if (d1 || d2)
        dirs.push_back({d1, d2, d1 * stride[a1] + d2 * stride[a2],
                        std::hypot(static_cast<double>(d1) * g.spacing[a1],
                                   static_cast<double>(d2) * g.spacing[a2])});
  // Superficial: a walk along one direction leaves the body within the depth (the scan's border
  // is not outside: the body goes on there).
  const auto superficial = [&](const std::int64_t at[3], std::size_t n) {
    for (const Direction& d : dirs) {
      std::int64_t p1 = at[a1], p2 = at[a2];
      auto m = static_cast<std::int64_t>(n);
      for (double s = d.mm; s <= depth + 1e-9; s += d.mm) {
        p1 += d.d1, p2 += d.d2, m += d.step;
        if (p1 < 0 || p2 < 0 || p1 >= g.dims[a1] || p2 >= g.dims[a2]) break;
        if (!body.data[static_cast<std::size_t>(m)]) return true;
      }
    }
    return false;
  };
  // Beside gas: a face neighbour below the body threshold (lung, bowel gas). A sharp kernel's
  // overshoot along a gas edge is a thin bright rod there; a rib lies in soft tissue.
  const int air = integer_floor(params.body_threshold_hu);
  const auto gas = [&](std::int64_t m) { return ct.data[static_cast<std::size_t>(m)] <= air; };
  const std::int64_t ny = g.dims[1], nz = g.dims[2];
  for (std::int64_t row = 0; row < ny * nz; ++row) {
    const std::int64_t j = row % ny, k = row / ny;
    for (std::int64_t r = runs.row_start[row]; r < runs.row_start[row + 1]; ++r) {
      const auto c = static_cast<std::size_t>(labels.of_run[r]);
      for (std::int64_t i = runs.runs[r].begin; i < runs.runs[r].end && rib[c]; ++i) {
        const std::int64_t at[3] = {i, j, k};
        const std::size_t n = g.linear(i, j, k);
        if (!superficial(at, n) || any_face_neighbour(g, n, gas)) rib[c] = 0;
      }
    }
  }
  return rib;
}

}  // namespace palp::segmentation
