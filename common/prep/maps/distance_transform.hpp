// Exact signed Euclidean distance maps with anisotropic spacing (spec "Masks and distance maps"):
//   inside the mask:   D = dist(centre, nearest outside voxel centre) - h/2
//   outside the mask:  D = -(dist(centre, nearest inside voxel centre) - h/2)
// h = the smallest spacing. Values are clamped to [-band, +band].
//
// Separable lower-envelope algorithm (Felzenszwalb & Huttenlocher / Meijster), linear in the
// voxel count, multithreaded over lines. Both signs come out of one sweep over the grid.
#pragma once

#include "base/volume.hpp"

namespace palp {

// The largest distance band (mm): 1 km means "no clamping" for any body; beyond it the crop's
// integer arithmetic would overflow (--band 1e308).
inline constexpr double kMaxBandMm = 1e6;

// UsageError unless `band_mm` is in (0, kMaxBandMm]: the one check of --band, made by palp prep
// as it parses it, by run_prep and by both distance transforms.
void check_distance_band(double band_mm);

// Which voxels receive their distance. One side costs about half of both on a dense mask, and
// next to nothing on the lines that hold no voxel of it (a sparse mask's inside).
enum class DistanceSide {
  both,     // every voxel
  inside,   // the mask's voxels; the others hold a value <= 0 that is not their distance
  outside,  // the others; the mask's voxels hold a value >= 0 that is not their distance
};

struct DistanceParams {
  double band_mm = 60.0;  // |D| is clamped here; work is cropped to the mask's box + band
  unsigned threads = 0;   // 0 = default_thread_count()
  DistanceSide side = DistanceSide::both;
};

// Signed distance map of `mask` on its own grid, voxel for voxel.
DistanceMap signed_distance(const Mask& mask, const DistanceParams& params = {});

// The same, written into `out`, whose memory is reused when it already holds a volume of the
// same voxel count (computing several maps of one grid then touches fresh memory only once).
void signed_distance(const Mask& mask, const DistanceParams& params, DistanceMap& out);

}  // namespace palp
