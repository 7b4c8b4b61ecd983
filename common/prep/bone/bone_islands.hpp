// Compact detached islands: calculi and calcifications, not bone (bone_islands.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "prep/segment/components.hpp"
#include "prep/segment/segmentation.hpp"

namespace palp::segmentation {

// The shape of each component of a run table: its principal spreads and whether it reaches the
// scan's border.
struct IslandShape {
  // Standard deviations (mm) of the voxel centres along the principal axes, largest first, each
  // voxel counted as a box (its own spacing^2 / 12 added per axis): a rod L mm long has
  // sd[0] = L / sqrt(12).
  std::array<double, 3> sd{};
  bool border = false;  // a voxel on the scan's first or last index along some axis
};
std::vector<IslandShape> island_shapes(const Grid& g, const RunTable& runs,
                                       const RunLabels& labels);

// Removes from `bone` (0/1) every island (6-connected) other than the largest that does not reach
// the scan's border, is shorter than params.bone_calculus_max_length_mm along its principal axis
// (the length of a rod with the same spread, 2*sqrt(3) standard deviations, each voxel counted as
// a box), is compact (its largest standard deviation under kBoneIslandElongation times its
// smallest: neither a rod nor a plate) and has no other bone's voxel centre within
// kBoneJointGapMm plus the largest spacing of one of its own. Nothing with
// bone_calculus_max_length_mm 0.
//
// Why: a bone of the trunk that the scan shows apart from the skeleton is a rib or a costal
// cartilage segment (long and thin, however it is cut), a plate, an arm's bone (long), or a piece
// the scan's edge cuts off (it reaches the border). A detached, compact, dense object shorter than
// a few cm inside the body is a stone (kidney, gallbladder, ureter), a calcified lymph node, a
// phlebolith or a pancreatic or vessel-wall calcification: dense like cortex, but no bone. The
// largest island is the skeleton and always stays; a small compact bone that the scan shows apart
// from its neighbour across a joint space or growth plate (a coccygeal segment, a carpal bone, an
// ossification centre, an arch across its facet joints) lies within a few mm of it and stays too.
void remove_compact_islands(const SegmentationParams& params, Mask& bone);

// Whether bone other than island `c` (of `labels` over `runs`, the runs of `bone`; its box
// [lo, hi]) has a voxel centre within `reach_mm` of one of the island's.
bool near_other_bone(const Mask& bone, const RunTable& runs, const RunLabels& labels,
                     std::int64_t c, const std::array<std::int64_t, 3>& lo,
                     const std::array<std::int64_t, 3>& hi, double reach_mm);

// A rib or cartilage segment is at least this many times as long as thick, a plate this many
// times as wide as thick (standard deviations along the largest and smallest principal axes); a
// stone or node is roundish or ovoid, below it.
inline constexpr double kBoneIslandElongation = 3.0;
// Joint spaces, discs' rims at the facets and growth plates that separate a bone from its
// neighbour are a few mm wide: an island with other bone within this gap (voxel centres within it
// plus the largest spacing) is kept.
inline constexpr double kBoneJointGapMm = 6.0;

}  // namespace palp::segmentation
