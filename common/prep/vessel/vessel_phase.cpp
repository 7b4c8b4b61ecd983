// The contrast phase (see vessel_phase.hpp). Data flow:
//   cores    the kept lumens' trunk cores -> 6-connected pieces, their shapes, boxes, levels
//   tubes    pieces -> those elongated and long enough, at the aorta's contrast
//   pairs    tubes -> two side by side: the darker one's level (the vein), else none
#include "prep/vessel/vessel_phase.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "prep/bone/bone_islands.hpp"
#include "prep/segment/components.hpp"
#include "prep/segment/segmentation.hpp"
#include "prep/vessel/vessel_segmentation.hpp"

namespace palp {

using segmentation::extract_runs;
using segmentation::label_runs;
using segmentation::RunLabels;
using segmentation::RunTable;

static_assert(kTubeElongation == segmentation::kBoneIslandElongation,
              "a trunk's tube is a rod as bone_islands measures one");

bool is_tube(const std::array<double, 3>& sd, double trunk_core_mm) {
  return sd[0] >= kTubeElongation * sd[1] &&
         2.0 * std::sqrt(3.0) * sd[0] >= kTubeMinLengthCores * trunk_core_mm;
}

ContrastPhase read_contrast_phase(const Mask& trunk_cores, const std::vector<std::int16_t>& hu,
                                  double soft_hu, double lumen_hu, const VesselParams& params) {
  const Grid& g = trunk_cores.grid;
  const RunTable t = extract_runs(trunk_cores, false);
  const RunLabels l = label_runs(g, t);
  const std::size_t count = l.voxels.size();
  const std::vector<segmentation::IslandShape> shapes = segmentation::island_shapes(g, t, l);
  const std::vector<segmentation::ComponentBox> boxes = segmentation::component_boxes(g, t, l);
  // per core: the sum of its smoothed HU and of its voxels' indices
  std::vector<double> sum(count, 0.0);
  std::vector<Vec3> centre(count, Vec3{0.0, 0.0, 0.0});
  const std::int64_t ny = g.dims[1];
  for (std::int64_t row = 0; row + 1 < static_cast<std::int64_t>(t.row_start.size()); ++row) {
    const std::int64_t j = row % ny, k = row / ny;
    for (std::int64_t r = t.row_start[row]; r < t.row_start[row + 1]; ++r) {
      const auto c = static_cast<std::size_t>(l.of_run[r]);
      for (std::int64_t i = t.runs[r].begin; i < t.runs[r].end; ++i) {
        sum[c] += hu[g.linear(i, j, k)];
        centre[c][0] += static_cast<double>(i);
        centre[c][1] += static_cast<double>(j);
        centre[c][2] += static_cast<double>(k);
      }
    }
  }
  const double half = soft_hu + 0.5 * (lumen_hu - soft_hu);
  std::vector<std::size_t> tubes;
  std::vector<double> level(count, 0.0);
  for (std::size_t c = 0; c < count; ++c) {
    const double v = static_cast<double>(l.voxels[c]);
    level[c] = sum[c] / v;
    for (double& x : centre[c]) x /= v;
    if (is_tube(shapes[c].sd, params.trunk_core_mm) && level[c] >= half) tubes.push_back(c);
  }
  const int slice = patient_axes(g).slice;
  double vein_hu = 0.0;
  for (std::size_t a = 0; a < tubes.size(); ++a)
    for (std::size_t b = a + 1; b < tubes.size(); ++b) {
      const std::size_t p = tubes[a], q = tubes[b];
      if (std::max(boxes[p].lo[slice], boxes[q].lo[slice]) >
          std::min(boxes[p].hi[slice], boxes[q].hi[slice]))
        continue;  // one above the other: one trunk's pieces, or two apart
      double across = 0.0;
      for (int axis = 0; axis < 3; ++axis)
        if (axis != slice) {
          const double d = (centre[p][axis] - centre[q][axis]) * g.spacing[axis];
          across += d * d;
        }
      if (std::sqrt(across) <= 2.0 * params.trunk_core_mm) continue;
      vein_hu = std::max(vein_hu, std::min(level[p], level[q]));
    }
  if (tubes.empty())
    return {lumen_hu - soft_hu >= params.arterial_above_soft_hu ? "arterial" : "portal-venous", 0.0,
            0.0};
  double tube_hu = 0.0;
  for (std::size_t c : tubes) tube_hu = std::max(tube_hu, level[c]);
  return {vein_hu > 0.0 ? "portal-venous" : "arterial", vein_hu, tube_hu};
}

}  // namespace palp
