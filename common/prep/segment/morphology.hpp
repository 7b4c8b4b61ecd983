// Face-neighbour morphology and arithmetic of whole 3-D masks on their own grid, row by row
// through raw pointers: a byte stored through a Mask's vector may alias the vector itself, so a
// loop written on `mask.data[n]` reloads its pointer and size at every voxel and never
// vectorizes. Outputs can reuse a mask's memory (no fresh pages for each step of a closing).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "base/parallel.hpp"
#include "base/volume.hpp"

namespace palp::segmentation {

// A box of voxels: lo <= (i, j, k) < hi.
struct VoxelBox {
  Index3 lo{0, 0, 0}, hi{0, 0, 0};
  std::int64_t size(int axis) const { return hi[axis] - lo[axis]; }
};

// The whole grid.
VoxelBox whole_grid(const Grid& g);

// The box of `mask`'s nonzero voxels grown by `margin` voxels on every side, within the grid
// (empty, lo == hi, when the mask is); slices scanned on `threads` (0: the default).
VoxelBox nonzero_box(const Mask& mask, std::int64_t margin, unsigned threads = 0);

// Calls row(j, k, centre, neighbours) for each row of `in` within `box` (j and k), `centre` the
// row's first voxel (i = 0) and `neighbours` the four rows beside it along j and k (a row of
// `outside` where the grid ends), over chunks of slices.
template <class Row>
void for_each_row_with_neighbours(const Mask& in, std::uint8_t outside, const VoxelBox& box,
                                  Row row) {
  const Grid& g = in.grid;
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const std::vector<std::uint8_t> beyond(static_cast<std::size_t>(nx), outside);
  parallel_for_chunks(box.hi[2] - box.lo[2], 2, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t k = box.lo[2] + k0; k < box.lo[2] + k1; ++k)
      for (std::int64_t j = box.lo[1]; j < box.hi[1]; ++j) {
        const std::uint8_t* c = &in.data[g.linear(0, j, k)];
        const std::uint8_t* side[4] = {
            j > 0 ? c - nx : beyond.data(), j + 1 < ny ? c + nx : beyond.data(),
            k > 0 ? c - nx * ny : beyond.data(), k + 1 < nz ? c + nx * ny : beyond.data()};
        row(j, k, c, side);
      }
  });
}

// `out` as a copy of `in`, its memory reused when it holds as many voxels.
void copy_into(const Mask& in, Mask& out);

// Dilation by one voxel (face neighbours) into voxels `allowed` says yes to, written to `out`;
// only the voxels in `box` are judged (the others are copied: a box holding the mask grown by a
// voxel loses nothing). `allowed` is asked only beside the mask.
template <class Allowed>
void dilate_into(const Mask& in, Allowed allowed, Mask& out, const VoxelBox& box) {
  copy_into(in, out);
  const Grid& g = in.grid;
  const std::int64_t nx = g.dims[0];
  std::uint8_t* to = out.data.data();
  for_each_row_with_neighbours(
      in, 0, box,
      [&](std::int64_t j, std::int64_t k, const std::uint8_t* c, const std::uint8_t* const* side) {
        const std::size_t first = g.linear(0, j, k);
        for (std::int64_t i = box.lo[0]; i < box.hi[0]; ++i) {
          if (c[i]) continue;
          const bool beside = (i > 0 && c[i - 1]) || (i + 1 < nx && c[i + 1]) || side[0][i] ||
                              side[1][i] || side[2][i] || side[3][i];
          if (beside && allowed(first + static_cast<std::size_t>(i)))
            to[first + static_cast<std::size_t>(i)] = 1;
        }
      });
}

template <class Allowed>
void dilate_into(const Mask& in, Allowed allowed, Mask& out) {
  dilate_into(in, allowed, out, whole_grid(in.grid));
}

// Dilation by one voxel (face neighbours) everywhere: a voxel of `in` keeps its value, a voxel
// beside one becomes 1.
Mask dilate_once(const Mask& in);

// Erosion by one voxel (face neighbours; the scan's border keeps its voxels), written to `out`
// (0/1); only the voxels in `box` are judged, the others copied.
void erode_into(const Mask& in, Mask& out, const VoxelBox& box);
void erode_into(const Mask& in, Mask& out);

// mask |= other
void unite(const Mask& other, Mask& mask);

// mask &= !other
void remove(const Mask& other, Mask& mask);

}  // namespace palp::segmentation
