// The skin preset on the sub-voxel skin: the render scalar composed from d_surf alone, whose zero
// level is the skin prep found between the CT's voxels (docs/prep.md), and a preset whose opacity
// steps up sharply there. Pure: no VTK (volume_layer.cpp turns it into the volume's scalars and
// transfer functions).
//
// Why: ray-casting the CT's HU shows the skin where the interpolated HU crosses the preset's
// level, inside the body mask. On a 3 mm CT the mask is a staircase of 3 mm voxels and the HU
// outside it are made air, so the skin shows 3 mm terraces. d_surf comes with every render
// volume anyway (the shadow and the deformation read it); its zero level is the sub-voxel skin.
//
// Composition: d_surf smoothed by one pass of the binomial [1 2 1] / 4 along each axis, then
//   s = kAirValue + kSkinStep * clamp((d + w) / 2w, 0, 1)
// air -1000, the skin -500, 0 deep inside. s is linear in d wherever |d| < w, and
//   w = max(kRampHalfWidthMm, 2 * the voxel's diagonal)
// so every voxel of a cell the skin crosses (|d| <= one diagonal: a distance changes by no more
// than the distance travelled), and those the ray caster's central-difference gradient reads one
// voxel further, lie on the linear part: the trilinear s crosses -500 where the trilinear d
// crosses 0, and its gradient (the shading) is d's, not a clamp's crease.
// The smoothing: d_surf's nodes carry errors of a few tenths of a millimetre on a 3 mm CT
// (docs/prep.md) that change sign from one node to the next; central differences over one
// voxel turn them into normals tilted by several degrees, and a smooth skin shows dents. The
// pass cancels what alternates from node to node (its response at the grid's highest
// frequency is 0), keeps linear d exactly (the ends extrapolated linearly), and moves the skin
// by sum_a (h_a^2 / 4) d_aa: at most h^2 / (2 r) on a surface of curvature radius r (0.15 mm at
// 3 mm voxels on a 30 mm ball, < 0.03 mm on a body's 150 mm).
// The volume's outermost voxels are air: where the scan's field of view cuts the body (its top
// and bottom slices, an arm at the edge) the skin closes there in a flat, lit cut, half a voxel
// inside the last one, instead of rays that start inside the body and shade it dark. Elsewhere
// they lie in the air palpd keeps around the body (kCropMarginMm) and nothing changes.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "render/transfer_presets.hpp"

namespace palp::view {

// The half-width w (mm) of the linear part for a volume of this spacing (mm between voxels).
double skin_ramp_half_width_mm(const std::array<double, 3>& spacing);

// d_surf smoothed as above, in place (i fastest; dims[0] * dims[1] * dims[2] values).
void smooth_distance(std::span<float> d, const std::array<std::int64_t, 3>& dims);

// s for every voxel (i fastest), with w from `spacing`, the outermost voxels air. UsageError when
// d_surf does not hold dims' voxels.
std::vector<float> compose_skin_scalar(std::span<const float> d_surf,
                                       const std::array<std::int64_t, 3>& dims,
                                       const std::array<double, 3>& spacing);

// The skin preset on s: transparent outside the skin, opaque and shaded from the skin inwards,
// the step centred on -500 (d = 0) and kSkinStepWidth wide in s: 0.2 % of the ramp's 1000, so
// d within +-0.002 w (+-0.02 mm on a 3 mm CT). Sharper than the ray caster's samples (half a
// voxel apart) can resolve: the skin shows where the first sample past d = 0 lies.
inline constexpr double kSkinStepWidth = 2.0;
Preset make_skin_surface_preset();

// Which scalar the volume is ray-cast through.
enum class ScalarKind {
  Maps,  // the maps' pseudo-density (compose_render_scalar): no CT
  Hu,    // the CT's HU inside the body (compose_ct_scalar)
  Skin,  // the sub-voxel skin (compose_skin_scalar)
};
// The skin preset takes the sub-voxel skin unless `skin_from_volume` (then, like every other
// preset, the CT's HU when the volume has them, else the maps' pseudo-density).
ScalarKind scalar_kind(PresetId preset, bool has_hu, bool skin_from_volume);
// The preset's definition on that scalar (its default window included).
Preset make_preset_on(ScalarKind kind, PresetId id);

}  // namespace palp::view
