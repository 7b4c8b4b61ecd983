// Oblique CTs (gantry tilt, a rotated direction matrix) are resampled onto the nearest
// axis-aligned frame before prep, so "posterior", "superior" and the table's side are index axes
// again and the maps keep overlaying the CT in other viewers (the new grid's direction and origin
// are written with them).
//
// The new grid: each index axis keeps its spacing and takes the patient axis nearest to it (same
// sign), the box covers the whole rotated volume, and values are trilinear in HU; voxels that
// fall outside the original volume are air (-1000 HU).
#pragma once

#include <string_view>

#include "base/volume.hpp"

namespace palp {

// Below this obliquity (degrees; 0.44 mm over 500 mm) a volume is taken as axis-aligned.
inline constexpr double kAxisAlignedToleranceDeg = 0.05;
// Resampling an oblique volume may grow it at most this much (the box around a rotated box).
inline constexpr double kMaxReorientGrowth = 4.0;

// The axis-aligned grid an oblique grid is resampled onto. InputError when an index axis is
// 45 degrees or more from every patient axis (no nearest axis to keep) or the box would grow
// beyond kMaxReorientGrowth.
Grid axis_aligned_grid(const Grid& grid);

// `ct` on axis_aligned_grid(ct.grid). The caller checks the obliquity first.
CtVolume resample_axis_aligned(const CtVolume& ct);

// `ct` resampled onto any `target` grid placed in the same world (both directions must be
// rotations, possibly mirrored): trilinear in HU, air (-1000) outside the source volume.
CtVolume resample(const CtVolume& ct, const Grid& target);

// The same voxels stored in another axis order: `code` names the patient direction each new
// index axis grows toward ("RAS", "LPS", "SLP", ...). The world placement follows, so the volume
// is the same patient in the same place; only the voxel order and the direction matrix change.
// UsageError for a code that is not three distinct axes; InputError for an oblique volume.
CtVolume reorder_axes(const CtVolume& ct, std::string_view code);

}  // namespace palp
