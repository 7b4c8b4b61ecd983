// The part of a scan the vessel search needs (vessel_search_box), and volumes cut to such a box
// and put back.
#pragma once

#include "base/volume.hpp"
#include "prep/segment/morphology.hpp"
#include "prep/vessel/vessel_segmentation.hpp"

namespace palp {

// Where the search can change or look: the body's voxels at the candidates' level or brighter
// (soft_peak_hu + min_contrast_hu: contrast, bone, calcium; everything else is soft tissue, fat or
// air) grown by the farthest any step looks from them (the walls' rays, marrow_enclosure_mm; an
// outline's rays, its largest radius and the calcium behind it) and two voxels; along the body
// axis the whole scan (the branches grown from the scan's ends need its ends). Empty when no
// voxel is that bright.
segmentation::VoxelBox vessel_search_box(const CtVolume& ct, const Mask& body, double soft_peak_hu,
                                         const VesselParams& params = {});

// Whether working on `box` instead of the whole grid of `voxels` saves a tenth of it or more
// (false for an empty box): below that, a crop and a paste cost more than they save.
bool box_saves_a_tenth(const segmentation::VoxelBox& box, std::size_t voxels);

// `v`'s voxels in `box` (within v's grid), on a grid that places them where they were.
CtVolume crop(const CtVolume& v, const segmentation::VoxelBox& box);
Mask crop(const Mask& v, const segmentation::VoxelBox& box);

// Writes `part` (a crop to `box`) back over `box` of `whole`.
void paste(const Mask& part, const segmentation::VoxelBox& box, Mask& whole);

}  // namespace palp
