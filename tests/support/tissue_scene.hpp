// A small CT scene for bone-mask tests: soft tissue in air, with boxes of other HU painted in,
// its bone mask and voxel counts (bone_marrow_test, bone_enclosure_test).
#pragma once

#include <cstdint>

#include "base/volume.hpp"
#include "prep/segment/segmentation.hpp"

namespace palp::testing {

// Soft tissue (40 HU) filling x, y in [5, 95) of a 100 x 100 x 60 grid at 1 mm, air around it.
inline CtVolume tissue_scene() {
  Grid g;
  g.dims = {100, 100, 60};
  CtVolume ct(g, -1000, "test scene");
  for (std::int64_t k = 0; k < 60; ++k)
    for (std::int64_t j = 5; j < 95; ++j)
      for (std::int64_t i = 5; i < 95; ++i) ct.at(i, j, k) = 40;
  return ct;
}

// Sets the voxels of [lo, hi) to `hu`.
inline void box(CtVolume& ct, Index3 lo, Index3 hi, std::int16_t hu) {
  for (std::int64_t k = lo[2]; k < hi[2]; ++k)
    for (std::int64_t j = lo[1]; j < hi[1]; ++j)
      for (std::int64_t i = lo[0]; i < hi[0]; ++i) ct.at(i, j, k) = hu;
}

// The bone mask segment_bone makes of `ct` within its body.
inline Mask bone_of(const CtVolume& ct, const SegmentationParams& params = {}) {
  const Mask body = segment_body(ct, params);
  return segment_bone(ct, body, params);
}

// Voxels set in `m` within [lo, hi).
inline std::int64_t count_in(const Mask& m, Index3 lo, Index3 hi) {
  std::int64_t n = 0;
  for (std::int64_t k = lo[2]; k < hi[2]; ++k)
    for (std::int64_t j = lo[1]; j < hi[1]; ++j)
      for (std::int64_t i = lo[0]; i < hi[0]; ++i) n += m.at(i, j, k) != 0;
  return n;
}

}  // namespace palp::testing
