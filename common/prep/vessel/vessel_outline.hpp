// A lumen's round outline across the body axis: a dissected aorta's false lumen
// (vessel_outline.cpp).
#pragma once

#include <cstdint>

#include "base/volume.hpp"

namespace palp {

struct VesselParams;

// Fills each lumen's round outline in the slices across the body axis and returns how many voxels
// that added. In every such slice, each 4-connected piece of `lumen` of at least
// kOutlineMinSectionMm2 casts kOutlineRays rays from its centre through the lumen and the tissue
// beside it. A ray ends on the vessel's edge where it meets a voxel below `edge_hu` (fat or air:
// half way from the scan's fat peak to its soft-tissue peak). Cortex (`cortex`, or HU at or above
// `cortex_hu`) with the lumen within kOutlineCalciumMm behind it is a calcified flap or intima and
// the ray goes on; with fat that near behind it, a calcified wall, and the edge lies behind it;
// anything else is bone and the ray gives up, as one that runs past
// params.outline_max_radius_mm or out of the scan. A circle is fitted to the edge points (least
// squares; points more than kOutlineOutlierMm off it dropped and the circle fitted again, up to
// three times). It is the vessel's when at least params.outline_min_edge_share of the rays give a
// point on it, at most kOutlineMaxCalcifiedShare of them behind calcium, its radius lies between
// kOutlineMinRadiusMm and outline_max_radius_mm, the points lie within params.outline_max_rms_mm
// of it (RMS) and the piece fills at least kOutlineMinLumenShare of it. Inside it the voxels at or
// above `edge_hu` are the lumen's (on its edge, those at least half vessel by their HU: the
// wall's partial volume with the fat), cortex among them only a voxel and a half in from the
// edge (a calcified flap; the wall's own calcium stays out).
// Nothing with outline_max_radius_mm 0.
//
// Why: a dissection parts the aorta into a true lumen, which fills with contrast in the arterial
// phase, and a false lumen whose blood flows slowly and stays at soft-tissue HU (on the shared
// contrast case 11,261 of the aorta's 72,810 voxels, median 60 HU against a soft-tissue peak of
// 57). No level tells it from the tissue around the aorta; its shape does: the two lumens fill
// one round vessel, which lies in fat (the periaortic fat, the lung beside the descending aorta)
// along most of its outline. Organs and muscles an artery rests on (the crus, the oesophagus,
// the heart's wall) touch it along less of its outline and do not follow the circle. A vertebral
// body is round too, but its outline is cortex (more than half of its points behind calcium) and
// what a lumen search took of its marrow fills little of it.
std::uint64_t fill_round_outlines(const CtVolume& ct, const Mask& cortex, double edge_hu,
                                  double cortex_hu, const VesselParams& params, Mask& lumen);

// Rays cast from a lumen's centre in each slice.
inline constexpr int kOutlineRays = 48;
// A lumen's piece smaller than this across (mm^2) is a branch's, too small to fit a circle to.
inline constexpr double kOutlineMinSectionMm2 = 25.0;
// Circles smaller than this radius (mm) are left as they are: small vessels have no false lumen
// a trainee could feel, and their fit rests on a few voxels.
inline constexpr double kOutlineMinRadiusMm = 5.0;
// An edge point this far off the circle (mm) is another structure touching the vessel.
inline constexpr double kOutlineOutlierMm = 3.0;
// A calcified flap or intima with its partial volume is at most this thick (mm; 4 voxels at
// 1.5 mm): the lumen or, behind a calcified wall, fat lies this near behind it.
inline constexpr double kOutlineCalciumMm = 6.0;
// The contrast-filled lumen fills at least this share of its vessel's section (the true lumen of
// a dissection: 0.31 where the shared contrast case's false lumen is widest, slice 48).
inline constexpr double kOutlineMinLumenShare = 0.15;
// At most this share of a vessel's edge points lie behind calcium; a bone's outline is cortex.
inline constexpr double kOutlineMaxCalcifiedShare = 0.5;

}  // namespace palp
