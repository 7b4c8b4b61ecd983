// Face-neighbour morphology of whole masks (see morphology.hpp).
#include "prep/segment/morphology.hpp"

#include <algorithm>
#include <vector>

namespace palp::segmentation {

VoxelBox whole_grid(const Grid& g) {
  return {{0, 0, 0}, g.dims};
}

VoxelBox nonzero_box(const Mask& mask, std::int64_t margin, unsigned threads) {
  const Index3 n = mask.grid.dims;
  const auto slices = static_cast<std::size_t>(n[2]);
  std::vector<std::int64_t> lo_i(slices, n[0]), hi_i(slices, -1), lo_j(slices, n[1]),
      hi_j(slices, -1);
  parallel_for_chunks(
      n[2], 4,
      [&](std::int64_t k0, std::int64_t k1) {
        for (std::int64_t k = k0; k < k1; ++k) {
          const auto kk = static_cast<std::size_t>(k);
          for (std::int64_t j = 0; j < n[1]; ++j) {
            const std::uint8_t* row = &mask.data[mask.grid.linear(0, j, k)];
            const std::uint8_t* first =
                std::find_if(row, row + n[0], [](std::uint8_t v) { return v != 0; });
            if (first == row + n[0]) continue;
            const std::uint8_t* last = row + n[0] - 1;
            while (*last == 0) --last;
            lo_i[kk] = std::min<std::int64_t>(lo_i[kk], first - row);
            hi_i[kk] = std::max<std::int64_t>(hi_i[kk], last - row);
            lo_j[kk] = std::min(lo_j[kk], j);
            hi_j[kk] = std::max(hi_j[kk], j);
          }
        }
      },
      threads);
  VoxelBox box{n, {-1, -1, -1}};
  for (std::int64_t k = 0; k < n[2]; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    if (hi_i[kk] < 0) continue;
    box.lo = {std::min(box.lo[0], lo_i[kk]), std::min(box.lo[1], lo_j[kk]), std::min(box.lo[2], k)};
    box.hi = {std::max(box.hi[0], hi_i[kk] + 1), std::max(box.hi[1], hi_j[kk] + 1),
              std::max(box.hi[2], k + 1)};
  }
  if (box.hi[0] < 0) return {};
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = std::max<std::int64_t>(0, box.lo[a] - margin);
    box.hi[a] = std::min(n[a], box.hi[a] + margin);
  }
  return box;
}

void copy_into(const Mask& in, Mask& out) {
  if (out.data.size() != in.data.size()) {
    out = in;
    return;
  }
  out.grid = in.grid;
  std::copy(in.data.begin(), in.data.end(), out.data.begin());
}

Mask dilate_once(const Mask& in) {
  Mask out = in;
  const std::int64_t nx = in.grid.dims[0];
  std::uint8_t* to = out.data.data();
  for_each_row_with_neighbours(
      in, 0, whole_grid(in.grid),
      [&](std::int64_t j, std::int64_t k, const std::uint8_t* c, const std::uint8_t* const* side) {
        std::uint8_t* row = to + in.grid.linear(0, j, k);
        const std::uint8_t *a = side[0], *b = side[1], *d = side[2], *e = side[3];
        for (std::int64_t i = 1; i + 1 < nx; ++i) {
          const int any = c[i - 1] | c[i + 1] | a[i] | b[i] | d[i] | e[i];
          row[i] = c[i] != 0 ? c[i] : static_cast<std::uint8_t>(any != 0);
        }
        for (std::int64_t i : {std::int64_t{0}, nx - 1}) {
          if (c[i]) continue;
          row[i] = (i > 0 && c[i - 1]) || (i + 1 < nx && c[i + 1]) || a[i] || b[i] || d[i] || e[i];
        }
      });
  return out;
}

void erode_into(const Mask& in, Mask& out, const VoxelBox& box) {
  copy_into(in, out);
  const Grid& g = in.grid;
  const std::int64_t nx = g.dims[0];
  std::uint8_t* to = out.data.data();
  for_each_row_with_neighbours(
      in, 1, box,
      [&](std::int64_t j, std::int64_t k, const std::uint8_t* c, const std::uint8_t* const* side) {
        const std::size_t first = g.linear(0, j, k);
        for (std::int64_t i = box.lo[0]; i < box.hi[0]; ++i) {
          if (!c[i]) continue;
          to[first + static_cast<std::size_t>(i)] = (i == 0 || c[i - 1]) &&
                                                    (i + 1 == nx || c[i + 1]) && side[0][i] &&
                                                    side[1][i] && side[2][i] && side[3][i];
        }
      });
}

void erode_into(const Mask& in, Mask& out) {
  erode_into(in, out, whole_grid(in.grid));
}

void unite(const Mask& other, Mask& mask) {
  const std::uint8_t* o = other.data.data();
  std::uint8_t* m = mask.data.data();
  const std::size_t count = mask.size();
  for (std::size_t n = 0; n < count; ++n) m[n] = static_cast<std::uint8_t>(m[n] | o[n]);
}

void remove(const Mask& other, Mask& mask) {
  const std::uint8_t* o = other.data.data();
  std::uint8_t* m = mask.data.data();
  const std::size_t count = mask.size();
  for (std::size_t n = 0; n < count; ++n) m[n] = o[n] != 0 ? 0 : m[n];
}

}  // namespace palp::segmentation
