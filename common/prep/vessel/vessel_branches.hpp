// Branches of the contrast-filled lumens and the marrow cortex walls in (see
// vessel_segmentation.hpp, "branches" and "marrow"): both ask along the six axis rays whether
// cortex encloses a voxel as a vertebral body's shell encloses its marrow.
#pragma once

#include <cstdint>
#include <vector>

#include "base/volume.hpp"
#include "prep/vessel/vessel_segmentation.hpp"

namespace palp {

// Voxels of `of` from which at least `min_sides` of the six axis rays meet cortex (`ridge`, or HU
// at or above `cortex_hu`, outside `of`) within `reach_mm`, passing only through voxels of `of` or
// at or above `through_hu` (enhanced: blood, marrow); a ray that meets anything darker (soft
// tissue, fat) or runs out of reach or out of the scan does not count.
Mask enclosed_by_cortex(const CtVolume& ct, const Mask& of, const Mask& ridge, double cortex_hu,
                        double through_hu, double reach_mm, int min_sides);

// `lumen` grown through voxels whose smoothed HU (`hu`) lies in the band of the brightest
// lumen's contrast (`lumen_hu`, above the soft tissue's `soft_hu`), whose own HU is below
// `cortex_hu`, that hold no voxel at or above it within branch_clearance_mm (face steps of the
// finest spacing), that are not a shell's ridge (`ridge` along branch_fence_ridge_directions of
// the 13 or more) and that cortex does not wall in on five sides of six within
// marrow_enclosure_mm. The band is judged only where the growth reaches. Then the branches the
// scan's end cuts off from their trunk: from the band's voxels on the first and last slice along
// the body axis that cortex does not wall in across it (on three of the four in-plane rays), in
// pieces no wider than pi trunk_core_mm^2 and on average no denser than `blood_hu`, grown
// through the band and kept where that growth is as big as a lumen (min_lumen_ml) and a tube.
// `blood_hu`, the contrast blood's level: the larger of the brightest lumen's mean and its
// brightest tube core's, each only ever diluted (the first by organs a branch joins to the
// lumen, the second by a dissection's unfilled false lumen in the core).
void grow_branches(const CtVolume& ct, const Mask& body, const std::vector<std::int16_t>& hu,
                   const Mask& ridge, double soft_hu, double lumen_hu, double blood_hu,
                   double cortex_hu, const VesselParams& params, Mask& lumen);

}  // namespace palp
