// Contrast-filled vessels (the lumens of arteries, veins and the heart's chambers) from a CT in HU,
// and the contrast phase the scan was taken in (spec "Files": vessel.nii.gz, contrast_phase).
//
// Method, every level from the scan itself or in millimetres:
//   levels     the soft-tissue peak S of the scan's own histogram (hu_levels.hpp) and the cortex
//              level (bone seed + 400 HU: only cortical bone reaches it; bone_lumens.hpp)
//   smoothing  the HU averaged over each voxel's 3x3x3 neighbourhood (noise of a thin slice)
//   candidates body voxels whose smoothed HU lies at least min_contrast_hu above S and below the
//              cortex level, farther than one voxel from any voxel at the cortex level
//   lumens     the candidates' 6-connected parts that hold at least min_lumen_ml, touch the cortex
//              (the voxels beside it) along at most max_cortex_contact of their boundary faces —
//              bone's marrow and cancellous bone lie inside a cortical shell, a lumen rests on bone
//              along a strip of its wall at most — and are uniform: the spread of their smoothed HU
//              (standard deviation) at most max_spread_fraction of their level above S (a lumen
//              is blood and contrast mixed, cancellous bone a lattice of bone and fat)
//   closing    the lumens closed by closing_mm (a dissection's flap, a calcified plaque's shadow
//              inside a lumen), then grown by one voxel into voxels below the cortex level whose
//              HU passes halfway from S to the lumen's level (the wall's partial volume)
//   phase      from the level of the largest lumen above S: `none` without a lumen, `arterial` at
//              arterial_above_soft_hu or more, `portal-venous` below. A delayed phase (arteries
//              and veins both barely enhanced) reads `portal-venous` or `none`: this cannot tell it
//              (docs/prep.md, "Vessels").
#pragma once

#include <cstdint>
#include <string>

#include "base/volume.hpp"

namespace palp {

struct VesselParams {
  double min_contrast_hu = 60.0;     // a lumen voxel's HU above the soft-tissue peak
  double min_lumen_contrast_hu = 90.0;  // a lumen's mean smoothed HU above the peak
  double trunk_core_mm = 6.0;        // a lumen holds a voxel this deep: joined to a trunk
  double split_mm = 2.0;             // bridges thinner than twice this part a lumen from bone
  double cortex_margin_hu = 400.0;   // bright level = bone seed level + this: cortex or pool
  double pool_mm = 3.0;              // bright regions this thick are contrast, not cortex
  double max_pool_margin_hu = 1000.0;  // ... when below bone seed + this (dense cortex is above)
  double max_cortex_contact = 0.15;  // share of a lumen's boundary faces beside cortex
  double max_spread_fraction = 0.35; // HU standard deviation / (level - soft-tissue peak)
  double min_lumen_ml = 0.3;         // smaller parts are noise, calcifications, partial volume
  double closing_mm = 2.0;           // flap and plaque shadows filled inside a lumen
  double arterial_above_soft_hu = 170.0;  // the phase's level: aorta of an arterial phase
};

struct VesselResult {
  Mask lumen;                          // 0/1, CT grid
  std::string contrast_phase = "none"; // none | arterial | portal-venous | unknown
  double lumen_level_hu = 0.0;         // median smoothed HU of the largest lumen (0: none)
  int lumens = 0;                      // parts kept
  int rejected_shell = 0;              // parts dropped as enclosed by cortex
  int rejected_spread = 0;             // parts dropped as not uniform
  int rejected_surface = 0;            // parts dropped as brighter at their surface (bone)
  int rejected_thin = 0;               // parts dropped as joined to no trunk
  std::uint64_t voxels = 0;
};

// `soft_peak_hu`: the scan's soft-tissue peak (HuLevels); `bone_seed_hu`: the bone seed level in
// use. Throws UsageError when `body` is not on the CT's grid or a parameter is unusable.
VesselResult segment_vessels(const CtVolume& ct, const Mask& body, double soft_peak_hu,
                             double bone_seed_hu, const VesselParams& params = {});

}  // namespace palp
