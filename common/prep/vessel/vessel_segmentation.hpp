// Contrast-filled vessels (the lumens of arteries, veins and the heart's chambers) from a CT in HU,
// and the contrast phase the scan was taken in (spec "Files": vessel.nii.gz, contrast_phase).
//
// Method, every level from the scan itself or in millimetres:
//   levels     the soft-tissue peak S of the scan's own histogram (hu_levels.hpp) and the bone
//              seed level in use (which follows S)
//   cortex     bright ridges: voxels at or above the seed level with darker voxels (one and two
//              away, averaged, ridge_drop of their height above S lower) on BOTH sides along one
//              of the 13 directions: a shell up to three voxels thick (cortex over marrow, under
//              soft tissue) or a trabecula. A lumen's edge is a step and a pool of contrast is
//              flat, however bright: neither is a ridge
//   candidates body voxels min_contrast_hu above S, smoothed below the seed level +
//              max_pool_margin_hu (dense cortex), not a ridge nor beside one
//   parts      the candidates opened by split_mm (a bridge of partial volume thinner than twice
//              that parts a lumen from bone), 6-connected
//   lumens     parts of min_lumen_ml that hold a voxel trunk_core_mm deep (the aorta, a vena
//              cava, the heart: joined to a trunk), average min_lumen_contrast_hu above S, touch
//              cortex along at most max_cortex_contact of their boundary faces (marrow lies in
//              its cortex; a lumen rests on bone along a strip) unless they average
//              clear_contrast_hu above S (cancellous bone never does; a dissection's flap and the
//              heart's trabeculae count as contact) and touch it along at most
//              max_clear_contrast_contact unless they average cortical HU (a lumen, flap and
//              all, is open to its wall and fat along most of its surface; a part walled in
//              along more is marrow its cortex encloses, lifted above clear_contrast_hu by an
//              endplate a thick slice blurs into it, while no marrow averages cortical HU and
//              undiluted contrast, its round edge a ridge along its tangents, may), spread (HU
//              standard deviation) at most
//              max_spread_fraction of their height above S, and are not brighter at their
//              surface than inside (bone is, cortex over marrow; a lumen's edge is darker), and
//              have at most half their voxels walled in by cortex on all six axis rays (through
//              their own voxels, within marrow_enclosure_mm): a vertebral body's marrow between
//              its endplates is, a vessel runs on along its length
//   organs     a lumen whose mean smoothed HU lies below half way (organ_below_share) from S to
//              the brightest lumen's level L and which holds no tube (neither it nor a piece of
//              its trunk core is tube-shaped, the contrast phase's measure: so the heart joined
//              to the aorta stays whatever vein of denser contrast is brighter) is an enhancing
//              organ, not a vessel: a kidney's cortex or the spleen in the arterial phase enhance
//              to 150-250 HU, as uniform as a lumen and as thick as a trunk, but far below the
//              arteries; a vein that has filled only partly is a tube and stays. Where the scan
//              shows a lumen as a tube, a part holding none and dimmer than that tube is an organ
//              too, at any level: beside an aorta of 250 HU a kidney's cortex at 150 lies above
//              half way. A scan too short for any tube (a thin slab) has the half-way rule alone
//   rejoin     the lumens grown through the candidates the opening cut (branches), never
//              within a voxel of a rejected part nor within two of cortex
//   branches   the lumens grown through voxels at the brightest lumen's contrast L (smoothed HU
//              from half way between S and L, and at least min_lumen_contrast_hu above S, up to
//              L plus half its height above S), below cortical HU (the bone seed level +
//              cortex_margin_hu, the bone mask's cortex level: only cortical bone reaches it), with
//              no cortical voxel within branch_clearance_mm, not a shell's ridge (one along
//              branch_fence_ridge_directions of the 13 or more), and not walled in by
//              cortex (a ridge or cortical HU met within marrow_enclosure_mm through enhanced
//              voxels) on five of the six axis rays. A branch leaving a trunk carries the trunk's
//              contrast and lies apart from cortex where the opening cut it off and bone's levels
//              would take it (a carotid, a subclavian, the coeliac trunk); marrow at that level
//              lies behind its cortex (the ridge and its cortical voxels fence it) and inside it
//              (walled in). A branch 4-5 voxels across (a carotid, the coeliac trunk at 1.5 mm) is
//              darker two voxels out only along the long diagonals: a ridge along a few of the
//              13 directions, where a shell the test resolves is one along most of the 9 or more
//              that cross its plane (a plane holds at most 4 of them). A branch the scan's end
//              cuts off from its trunk (the subclavian above a chest crop) is grown from that end:
//              from the band's voxels on the first and last slice along the body axis that cortex
//              walls in on fewer than three of the four rays across it, in pieces no wider than
//              pi trunk_core_mm^2 (wider would hold a trunk's core) and on average no denser than L
//              (partial volume only darkens a thinner vessel); what grows from them stays where it
//              is a tube (vessel_phase.hpp) of min_lumen_ml or more: marrow grown from the end is
//              a blob, a vertebral column wider than a trunk's core, a rib walled in across
//   marrow     lumen voxels walled in by cortex on all six axis rays (within
//              marrow_enclosure_mm, through enhanced voxels) are not a lumen: a vertebral body's
//              marrow between its endplates that the scan's blurred cortex let through; a lumen
//              runs on along its length, however calcified its wall
//   closing    closed by closing_mm (a flap's shadow), then one voxel of contrast level beside
//              them and not by cortex (the wall's partial volume)
//   outline    in each slice across the body axis, a lumen's piece whose surroundings end on
//              fat or air along a circle (most of its outline, within outline_max_rms_mm of it)
//              takes the tissue inside that circle: a dissected aorta's false lumen, at
//              soft-tissue HU, and the vessel's wall (vessel_outline.hpp)
//   phase      from the veins beside the aorta, not from the aorta's level (a late arterial
//              aorta and a portal-venous one can be as bright): `none` without a lumen; else the
//              trunk cores (voxels trunk_core_mm deep) of the lumens, each 6-connected piece a
//              tube when it runs along one axis three times as far as across it (standard
//              deviations) over at least 4 trunk_core_mm, at the aorta's contrast when its mean
//              smoothed HU is at least half way from S to the brightest lumen's level. Two such
//              tubes side by side (sharing slices along the body axis, centres more than
//              2 trunk_core_mm apart across it) are the aorta and a large vein (the vena cava
//              beside it, the portal vein in front) filled as it is: `portal-venous`. One alone,
//              the veins barely enhanced (below min_contrast_hu, or under half the aorta's
//              height): `arterial`. None (a slab thinner than a tube is long: its trunks'
//              cores are short): from the brightest lumen's level, `arterial` at
//              arterial_above_soft_hu above S or more, `portal-venous` below (a late arterial
//              aorta then reads portal-venous). A delayed phase reads `portal-venous`. In the chest
//              an arterial phase shows tubes at the aorta's level side by side too (the ascending
//              and descending aorta where the arch does not join their cores, the pulmonary
//              arteries, the superior vena cava dense with the injected contrast): read there,
//              the rule can say `portal-venous`.
// Measured on the phantom's cases and the shared CTs in docs/anatomy.md, where it falls short:
// an organ enhancing to more than half the arteries' level and as uniform is taken with the
// lumens, and a dissected aorta's false lumen is found only where the aorta's outline is
// round and lies in fat.
#pragma once

#include <cstdint>
#include <string>

#include "base/volume.hpp"

namespace palp {

struct VesselParams {
  double min_contrast_hu = 60.0;        // a lumen voxel's HU above the soft-tissue peak
  double min_lumen_contrast_hu = 90.0;  // a lumen's mean smoothed HU above the peak
  double trunk_core_mm = 6.0;           // a lumen holds a voxel this deep: joined to a trunk
  double split_mm = 2.0;                // bridges thinner than twice this part a lumen from bone
  double ridge_drop = 0.35;             // cortex: a ridge, this share of its height above S lower
                                        // on both sides (bone_seed level and up)
  double max_pool_margin_hu = 1000.0;   // lumens below bone seed + this (dense cortex is above)
  double max_cortex_contact = 0.3;      // share of a lumen's boundary faces beside cortex
  double max_spread_fraction = 0.5;     // HU standard deviation / (level - soft-tissue peak)
  double clear_contrast_hu = 250.0;     // a part this far above S on average is contrast
  double max_clear_contrast_contact = 2.0 / 3.0;  // ... unless more of its faces are beside cortex
  double min_lumen_ml = 0.3;              // smaller parts are noise, calcifications, partial volume
  double closing_mm = 2.0;                // flap and plaque shadows filled inside a lumen
  double arterial_above_soft_hu = 170.0;  // the phase's level where no trunk is a tube (a slab)
  // A lumen below this share of the way from S to the brightest lumen's level that holds no
  // tube is an enhancing organ (the header's `organs`); 0: off.
  double organ_below_share = 0.5;
  bool find_branches = true;         // grow the lumens into branches (the header's method)
  double branch_clearance_mm = 3.0;  // no cortical voxel this near a branch's voxel
  // A ridge fences the branches where it is one along at least this many of the 13 directions
  // (a shell; a tube wider than the ridge test's two voxels is one only along a few diagonals).
  int branch_fence_ridge_directions = 5;
  // Cortical HU: the bone seed level + this, the bone mask's own cortex level
  // (SegmentationParams::bone_lumen_cortex_margin_hu; prep passes the bone's).
  double cortex_margin_hu = 400.0;
  double marrow_enclosure_mm = 30.0;  // marrow: cortex within this along the axis rays
  // The round outline (vessel_outline.hpp): a dissected aorta's false lumen. 0: off.
  double outline_max_radius_mm = 25.0;  // an aorta up to 50 mm across (a dissection widens it)
  double outline_min_edge_share = 0.5;  // rays ending on its edge (the rest: what it rests on)
  double outline_max_rms_mm = 2.25;     // the edge points' RMS distance from the circle
  // The scan's fat peak (prep passes HuLevels'): the vessel's edge is half way from it to the
  // soft-tissue peak.
  double fat_peak_hu = -100.0;
};

struct VesselResult {
  Mask lumen;                           // 0/1, CT grid
  std::string contrast_phase = "none";  // none | arterial | portal-venous | unknown
  double lumen_level_hu = 0.0;          // mean smoothed HU of the brightest lumen (0: none)
  double second_trunk_level_hu = 0.0;   // portal-venous: the darker of the two tubes (0: none)
  double tube_level_hu = 0.0;  // mean smoothed HU of the brightest tube's trunk core (0: none)
  int lumens = 0;              // parts kept
  int rejected_shell = 0;      // parts dropped as enclosed by cortex
  int rejected_spread = 0;     // parts dropped as not uniform
  int rejected_surface = 0;    // parts dropped as brighter at their surface (bone)
  int rejected_thin = 0;       // parts dropped as joined to no trunk
  int rejected_organ = 0;      // parts dropped as an enhancing organ (below, not a tube)
  std::uint64_t voxels = 0;
};

// `soft_peak_hu`: the scan's soft-tissue peak (HuLevels); `bone_seed_hu`: the bone seed level in
// use. Throws UsageError when `body` is not on the CT's grid or a parameter is unusable. The
// search runs on vessel_search_box's part of the scan (vessel_box.hpp) when that is less than nine
// tenths of it.
VesselResult segment_vessels(const CtVolume& ct, const Mask& body, double soft_peak_hu,
                             double bone_seed_hu, const VesselParams& params = {});

}  // namespace palp
