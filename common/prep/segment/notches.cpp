// Notch filling (see notches.hpp). A row's face counts are summed from its six neighbouring
// rows (a loop that vectorises), only over the span a voxel with a mask face can lie in; then
// each filled voxel's neighbours are looked at again.
#include "prep/segment/notches.hpp"

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "base/parallel.hpp"
#include "prep/segment/components.hpp"

namespace palp::segmentation {

namespace {

// Each row's span of the mask, [lo, hi) (empty: lo >= hi).
struct MaskRowSpans {
  std::vector<std::int64_t> lo, hi;
};

// The mask's span in every row, slices in parallel.
MaskRowSpans row_spans(const Mask& mask) {
  const Grid& g = mask.grid;
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const std::int64_t rows = ny * nz;
  MaskRowSpans spans{std::vector<std::int64_t>(static_cast<std::size_t>(rows)),
                     std::vector<std::int64_t>(static_cast<std::size_t>(rows))};
  parallel_for_chunks(nz, 2, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t r = k0 * ny; r < k1 * ny; ++r) {
      const std::uint8_t* row = mask.data.data() + r * nx;
      spans.lo[r] = next_byte(row, 0, nx, true);
      spans.hi[r] = spans.lo[r] < nx ? last_nonzero_byte(row, nx) + 1 : 0;
    }
  });
  return spans;
}

// The notches of the mask as it is, slice by slice, in slice order (each row's face counts
// summed from the six neighbouring rows, a loop that vectorises). A voxel outside the spans of
// its four neighbouring rows and its own row's span grown by one has no face on the mask, count
// 0 < faces: the scan leaves it out and finds the same notches in the same order.
std::vector<std::size_t> notches_now(const Mask& room, int faces, const Mask& mask,
                                     const MaskRowSpans& spans) {
  const Grid& g = mask.grid;
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  std::vector<std::vector<std::size_t>> found(static_cast<std::size_t>(nz));
  const std::vector<std::uint8_t> none(static_cast<std::size_t>(nx), 0);
  parallel_for_chunks(nz, 2, [&](std::int64_t k0, std::int64_t k1) {
    std::vector<std::uint8_t> counts(static_cast<std::size_t>(nx));
    std::uint8_t* count = counts.data();
    for (std::int64_t k = k0; k < k1; ++k)
      for (std::int64_t j = 0; j < ny; ++j) {
        const std::int64_t r = j + ny * k;
        std::int64_t lo = nx, hi = 0;
        const auto widen = [&](bool exists, std::int64_t o, std::int64_t by) {
          if (!exists || spans.lo[o] >= spans.hi[o]) return;
          lo = std::min(lo, std::max<std::int64_t>(0, spans.lo[o] - by));
          hi = std::max(hi, std::min(nx, spans.hi[o] + by));
        };
        widen(true, r, 1);
        widen(j > 0, r - 1, 0);
        widen(j + 1 < ny, r + 1, 0);
        widen(k > 0, r - ny, 0);
        widen(k + 1 < nz, r + ny, 0);
        if (lo >= hi) continue;
        const std::size_t first = g.linear(0, j, k);
        const std::uint8_t* row = mask.data.data() + first;
        const std::uint8_t* in_room = room.data.data() + first;
        const std::uint8_t* y0 = j > 0 ? row - nx : none.data();
        const std::uint8_t* y1 = j + 1 < ny ? row + nx : none.data();
        const std::uint8_t* z0 = k > 0 ? row - nx * ny : none.data();
        const std::uint8_t* z1 = k + 1 < nz ? row + nx * ny : none.data();
        for (std::int64_t i = lo; i < hi; ++i)
          count[i] = static_cast<std::uint8_t>(y0[i] + y1[i] + z0[i] + z1[i]);
        for (std::int64_t i = std::max<std::int64_t>(lo, 1); i < hi; ++i) count[i] += row[i - 1];
        for (std::int64_t i = lo; i < std::min(hi, nx - 1); ++i) count[i] += row[i + 1];
        for (std::int64_t i = lo; i < hi; ++i)
          if (count[i] >= faces && !row[i] && in_room[i])
            found[static_cast<std::size_t>(k)].push_back(first + static_cast<std::size_t>(i));
      }
  });
  std::vector<std::size_t> todo;
  for (const auto& slice : found) todo.insert(todo.end(), slice.begin(), slice.end());
  return todo;
}

}  // namespace

void fill_notches(const Mask& room, int faces, Mask& mask) {
  if (faces <= 0) return;
  const Grid& g = mask.grid;
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const std::int64_t steps[6] = {-1, 1, -nx, nx, -nx * ny, nx * ny};
  const auto open_faces = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return std::array<bool, 6>{i > 0, i + 1 < nx, j > 0, j + 1 < ny, k > 0, k + 1 < nz};
  };
  const auto mask_faces = [&](std::int64_t i, std::int64_t j, std::int64_t k, std::size_t n) {
    const std::array<bool, 6> in = open_faces(i, j, k);
    int c = 0;
    for (int d = 0; d < 6; ++d)
      c += in[d] && mask.data[static_cast<std::size_t>(static_cast<std::int64_t>(n) + steps[d])];
    return c;
  };
  const auto is_notch = [&](std::size_t n) {
    if (mask.data[n] || !room.data[n]) return false;
    const auto i = static_cast<std::int64_t>(n % static_cast<std::size_t>(nx));
    const auto jk = static_cast<std::int64_t>(n / static_cast<std::size_t>(nx));
    return mask_faces(i, jk % ny, jk / ny, n) >= faces;
  };
  // The notches of the mask as it is; then each filled voxel's neighbours again.
  std::vector<std::size_t> todo = notches_now(room, faces, mask, row_spans(mask));
  while (!todo.empty()) {
    const std::size_t n = todo.back();
    todo.pop_back();
    if (!is_notch(n)) continue;
    mask.data[n] = 1;
    const auto i = static_cast<std::int64_t>(n % static_cast<std::size_t>(nx));
    const auto jk = static_cast<std::int64_t>(n / static_cast<std::size_t>(nx));
    const std::array<bool, 6> in = open_faces(i, jk % ny, jk / ny);
    for (int d = 0; d < 6; ++d)
      if (in[d]) todo.push_back(static_cast<std::size_t>(static_cast<std::int64_t>(n) + steps[d]));
  }
}

}  // namespace palp::segmentation
