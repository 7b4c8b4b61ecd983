// Ribs whose peak the scan lowered under the seed level (bone_ribs.cpp).
#pragma once

#include <cstdint>
#include <vector>

#include "prep/segment/components.hpp"
#include "prep/segment/segmentation.hpp"

namespace palp::segmentation {

// Per component of the growable voxels (runs and labels of the candidate mask: seeds and voxels at
// or above the growing level), whether it is a rib that holds no seed: not `seeded`, at least
// params.min_bone_island_ml, a rod (its longest spread at least kBoneIslandElongation times the
// next, bone_islands.hpp) of rib width (kBoneRibMinWidthMm to kBoneRibMaxWidthMm), each of its
// voxels within params.bone_rib_depth_mm of the body's outside along one of the eight directions
// of its slice plane, and none beside gas (a face neighbour at or below params.body_threshold_hu).
// None with bone_rib_depth_mm 0.
//
// Why: the seed level is a fixed distance above the soft-tissue peak, not relative to a
// structure's own contrast. A rib is thin (a cortex around marrow, 10-15 mm across), so a softer
// reconstruction kernel or thicker voxels average its peak with the tissue around it and a whole
// rib can fall under the seed level while it still reaches the growing level. What else reaches
// the growing level without a seed in a long thin shape: a contrast-filled vessel or a
// fluid-filled tube (ureter, bowel loop), which lie in the body's cavities, deep, while the ribs
// and costal cartilage lie under the chest and abdominal wall; and a sharp kernel's overshoot along
// a gas edge (lung, bowel), which lies beside the gas where a rib lies in soft tissue. A thick
// structure (an enhanced muscle or organ) is not a rod of rib width.
std::vector<std::uint8_t> unseeded_ribs(const CtVolume& ct, const Mask& body,
                                        const PatientAxes& axes, const RunTable& runs,
                                        const RunLabels& labels,
                                        const std::vector<std::uint8_t>& seeded,
                                        const SegmentationParams& params);

// A rib, its costal cartilage included, is this wide at most (the larger spread of its cross
// section as the width of a band with the same spread, 2*sqrt(3) standard deviations; a curved
// piece's sagitta adds to it) and at least this wide (thinner rods are one-voxel lines: an edge's
// overshoot, not a rib, which is 10-15 mm wide).
inline constexpr double kBoneRibMaxWidthMm = 20.0;
inline constexpr double kBoneRibMinWidthMm = 6.0;

}  // namespace palp::segmentation
