// Contrast-filled lumens resting on bone: not bone (bone_lumens.cpp).
#pragma once

#include <cstdint>

#include "base/volume.hpp"
#include "prep/segment/segmentation.hpp"

namespace palp::segmentation {

// Removes from `bone` (the seeded regions, any nonzero value) the lumens and returns how many
// voxels that took. The cortex level is params.bone_seed_hu + params.bone_lumen_cortex_margin_hu;
// the bone's voxels from the seed level up to below it form pieces, apart from those beside a
// voxel at or above it (the rim). A piece that touches the rim, but with fewer than
// params.bone_lumen_max_contact of its surface voxels, is a candidate (one that touches no
// cortex at all stays); its lumen is its opening by a ball of params.bone_lumen_radius_mm and one
// voxel more: the voxels within that reach of a core voxel, one at least the radius from every
// voxel outside the candidates. The lumens go, and with them the rim voxels beside them that do
// not pass the edge trim's level (params.bone_edge_fraction) with the lumen as their outside: the
// lumen's own edge against the cortex. Nothing with bone_lumen_radius_mm 0.
//
// Why: in an arterial-phase or angiographic scan a vessel's lumen reaches the seed level itself
// (300-600 HU), so the region growing takes it whole, and where it rests on a vertebra or the
// pelvis it joins the skeleton. What tells bone from it: only bone reaches cortical HU; seed-level
// bone below that (dense marrow) is enclosed by its cortex, a broad contact, while a lumen rests
// on the cortex along a strip of its wall; and seed-level bone that is not enclosed by bright
// cortex is thin — a rib, a cortex blurred by thick voxels — where a lumen is a thick tube (the
// aorta 15-30 mm across). A rib or cortex up to twice the radius across holds no core, and so
// loses nothing. Bone's interior, if a piece of it went, is marrow the later marrow rules fill
// again (enclosed by the bone); a lumen lies outside the bone.
std::uint64_t remove_lumens(const CtVolume& ct, const SegmentationParams& params, Mask& bone);

}  // namespace palp::segmentation

namespace palp::segmentation {

// Removes from `bone` (0/1) every island (6-connected; not the largest, the skeleton) that is a
// filled lumen: it holds a core (voxels at least params.bone_lumen_radius_mm from every voxel
// outside it, as above) whose mean HU is below the cortex level (as above) and at least that of
// its surface voxels (those with a face neighbour outside it; the scan's border is not outside).
// Returns how many voxels went. Nothing with bone_lumen_radius_mm 0.
//
// Why: a lumen filled with contrast apart from the skeleton — bowel with positive oral contrast,
// the aorta of an arterial phase away from the spine, a bladder or renal pelvis of an excretory
// phase — holds seeds and grows into an island that remove_lumens does not see (it touches no
// cortex). Bone is brightest at its surface (the cortex) and darker inside (cancellous bone,
// marrow), so a bone thick enough to hold a core — a femoral or humeral head apart from its
// socket, a vertebra the scan separates — has its core below its surface; a filled lumen is
// uniform, and partial volume with its wall only lowers its surface. Ribs, costal cartilage and
// the sternum are thinner than twice the radius and hold no core, so they are never looked at. A
// core of cortical HU is bone whatever its surface (dense bone, or contrast this cannot tell from
// it: a bladder of excreted contrast above the cortex level stays).
std::uint64_t remove_lumen_islands(const CtVolume& ct, const SegmentationParams& params,
                                   Mask& bone);

}  // namespace palp::segmentation
