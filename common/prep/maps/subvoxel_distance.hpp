// Sub-voxel signed distance maps (spec "Masks and distance maps", `--surface subvoxel`): the
// distance to the HU iso-surface of a CT at a chosen level, restricted to the segmented
// components, with the mask's sign.
//
//   surface points  one per voxel edge whose two ends the mask puts on different sides, placed
//                   by linear interpolation of HU along that edge (midpoint when the HU do not
//                   straddle the level, e.g. where table removal or hole filling cut the mask),
//                   with the unit normal of the HU gradient there (3x3x3 Sobel)
//   narrow band     every voxel centre within `band_mm` of a point gets the distance to the
//                   nearest surface disc (the tangent disc of radius r around each point, r half
//                   the diagonal of the grid's two coarsest spacings, so the discs of a plane
//                   cover it), signed by the mask
//   beyond the band the exact distance to the points themselves (every point lies on a grid
//                   edge, so it is separable per edge axis: three lower-envelope transforms)
//
// Only edges where the mask changes carry points, so parts the segmentation removed (the table)
// have no surface and parts it kept (arms) do. Points are extracted while the CT is in memory;
// the maps need only the points and the masks. Values are rounded to 1/1024 mm.
#pragma once

#include <cstdint>
#include <vector>

#include "base/volume.hpp"

namespace palp {

struct SurfacePoint {
  float x, y, z;         // grid index coordinates times spacing (mm from voxel (0,0,0)'s centre)
  float nx, ny, nz;      // unit normal
  std::int32_t i, j, k;  // the edge's lower voxel
  std::int32_t axis;     // the edge's axis
  float t;               // the point's fraction along the edge, in [0, 1]
};

struct SurfacePoints {
  Grid grid;
  std::vector<SurfacePoint> points;      // ordered by the slice k of the edge's lower end
  std::vector<std::size_t> slice_begin;  // points of slice k: [slice_begin[k], slice_begin[k+1])
  std::size_t interpolated = 0;          // points placed by HU interpolation (not midpoints)
};

// The iso-surface points of `ct` at `iso_hu` on the edges where `mask` changes.
SurfacePoints surface_points(const CtVolume& ct, const Mask& mask, double iso_hu,
                             unsigned threads = 0);

// The sub-voxel signed map of `mask` into `out` (reused when it has the grid's voxel count):
// the distance to the points everywhere, then to the discs within `band_mm`, signed by the mask,
// clamped to +-clamp_mm. Needs no volume besides `out` (slice buffers per thread).
void subvoxel_signed_distance(const SurfacePoints& surface, const Mask& mask, double band_mm,
                              double clamp_mm, DistanceMap& out, unsigned threads = 0);

}  // namespace palp
