// The contrast phase a scan was taken in, read from its lumens' trunk cores (vessel_phase.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "base/volume.hpp"

namespace palp {

struct VesselParams;

struct ContrastPhase {
  std::string name;              // arterial | portal-venous
  double second_trunk_hu = 0.0;  // portal-venous: the darker tube of the brightest pair (0: none)
  double tube_hu = 0.0;          // the brightest tube's level (0: none)
};

// `trunk_cores`: the kept lumens' voxels trunk_core_mm deep (0/1, the CT's grid); `hu`: the
// smoothed CT; `soft_hu`: the scan's soft-tissue peak; `lumen_hu`: the brightest lumen's level.
// Each 6-connected core is a tube when it spreads along one axis at least kTubeElongation times
// as far as across it (standard deviations) over at least kTubeMinLengthCores trunk_core_mm, and
// at the aorta's contrast when its mean smoothed HU is at least half way from the soft tissue to
// `lumen_hu`. Two such tubes side by side (sharing slices along the body axis, their centres more
// than 2 trunk_core_mm apart across it: two lumens, not one) are the aorta and a large vein filled
// as it is: portal-venous. One alone: the veins have not filled yet, arterial. No tube (a slab
// thinner than a tube is long): arterial when `lumen_hu` is params.arterial_above_soft_hu or more
// above the soft tissue, else portal-venous.
//
// Why: a late arterial aorta and a portal-venous one can be as bright; what differs is the veins
// beside it (vena cava, portal vein), barely enhanced in the arterial phase and at the aorta's
// level in the portal-venous one. A kidney's or the heart's core is roundish, not a tube.
ContrastPhase read_contrast_phase(const Mask& trunk_cores, const std::vector<std::int16_t>& hu,
                                  double soft_hu, double lumen_hu, const VesselParams& params);

// A trunk's core is a tube (a length of aorta, vena cava, portal vein) when its voxels spread
// along one axis at least this many times as far as across it (standard deviations, as
// bone_islands' rods: segmentation::kBoneIslandElongation) ...
inline constexpr double kTubeElongation = 3.0;
// ... and its length (a rod's: 2 sqrt(3) standard deviations) is at least this many times
// trunk_core_mm, twice a trunk's least diameter: a shorter core is a trunk's bulge or a chamber's
// corner, not a run of vessel (a kidney's or the heart's core is roundish: neither).
inline constexpr double kTubeMinLengthCores = 4.0;

// Whether a core of these principal spreads (standard deviations, mm, largest first) is a tube
// by the two measures above.
bool is_tube(const std::array<double, 3>& sd, double trunk_core_mm);

}  // namespace palp
