// Runs of mask voxels along i, their 3D connected components, and row scans over masks.
#pragma once

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <vector>

#include "base/parallel.hpp"
#include "base/volume.hpp"

namespace palp::segmentation {

// Union-find over run indices. Roots are the smallest index of their set, so labels come out in
// a deterministic order.
class DisjointSets {
 public:
  void reset(std::size_t n) {
    parent_.resize(n);
    std::iota(parent_.begin(), parent_.end(), std::int64_t{0});
  }
  std::int64_t find(std::int64_t x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }
  void unite(std::int64_t a, std::int64_t b) {
    a = find(a);
    b = find(b);
    if (a < b) parent_[b] = a;
    if (b < a) parent_[a] = b;
  }

 private:
  std::vector<std::int64_t> parent_;
};

struct Run {
  std::int64_t begin;  // first voxel along the row
  std::int64_t end;    // one past the last
};

// Unites the runs of two neighbouring rows that touch: across a face (gap = 0) or also across an
// edge (gap = 1).
void unite_touching(const std::vector<Run>& runs, std::int64_t a, std::int64_t a_end,
                    std::int64_t b, std::int64_t b_end, std::int64_t gap, DisjointSets& sets);

// Byte scanning: the first position at or after i in row[0, n) whose byte is nonzero (or zero).
// Rows are read eight bytes at a time while no byte can match.

inline bool has_zero_byte(std::uint64_t w) {
  return ((w - 0x0101010101010101ull) & ~w & 0x8080808080808080ull) != 0;
}

inline std::int64_t next_byte(const std::uint8_t* row, std::int64_t i, std::int64_t n,
                              bool nonzero) {
  std::uint64_t w = 0;
  for (; i + 8 <= n; i += 8) {
    std::memcpy(&w, row + i, 8);
    if (nonzero ? w != 0 : has_zero_byte(w)) break;
  }
  while (i < n && (row[i] != 0) != nonzero) ++i;
  return i;
}

// The last nonzero byte of row[0, n), or -1 if none; read backwards eight bytes at a time while
// they are all zero.
inline std::int64_t last_nonzero_byte(const std::uint8_t* row, std::int64_t n) {
  std::uint64_t w = 0;
  for (; n >= 8; n -= 8) {
    std::memcpy(&w, row + n - 8, 8);
    if (w != 0) break;
  }
  while (n > 0 && row[n - 1] == 0) --n;
  return n - 1;
}

// Transposes an 8x8 block of bytes: dst[c * dst_stride + r] = src[r * src_stride + c] for r, c in
// [0, 8). Each row is one 64-bit word (byte c at bit 8c: little-endian), and three rounds swap
// the off-diagonal 1x1, 2x2 and 4x4 sub-blocks between pairs of rows one, two and four apart,
// each swap one shift, xor and mask: about 8x fewer operations than moving byte by byte.
inline void transpose_bytes_8x8(const std::uint8_t* src, std::int64_t src_stride, std::uint8_t* dst,
                                std::int64_t dst_stride) {
  static_assert(std::endian::native == std::endian::little, "byte c of a row must be bits 8c..");
  std::uint64_t w[8];
  for (int r = 0; r < 8; ++r) std::memcpy(&w[r], src + r * src_stride, 8);
  const auto swap = [&](int a, int b, int bits, std::uint64_t mask) {
    // The bytes of w[a] at the upper half of each 2*bits block trade places with those of w[b]
    // at the lower half.
    const std::uint64_t t = ((w[a] >> bits) ^ w[b]) & mask;
    w[b] ^= t;
    w[a] ^= t << bits;
  };
  for (int a = 0; a < 8; a += 2) swap(a, a + 1, 8, 0x00FF00FF00FF00FFull);
  for (const int a : {0, 1, 4, 5}) swap(a, a + 2, 16, 0x0000FFFF0000FFFFull);
  for (int a = 0; a < 4; ++a) swap(a, a + 4, 32, 0x00000000FFFFFFFFull);
  for (int c = 0; c < 8; ++c) std::memcpy(dst + c * dst_stride, &w[c], 8);
}

// 3D connected components (6-connected) of a mask's nonzero (or zero) voxels, as runs along i.

struct RunTable {
  std::vector<Run> runs;
  std::vector<std::int64_t>
      row_start;  // row r = j + ny*k holds runs [row_start[r], row_start[r+1])
};

// The runs of `mask`'s nonzero (or zero) voxels, row by row.
RunTable extract_runs(const Mask& mask, bool zeros);

struct RunLabels {
  std::vector<std::int64_t> of_run;  // component of each run
  std::vector<std::int64_t> voxels;  // voxel count of each component
};

// Labels the runs' 6-connected components, numbered in order of their first run.
RunLabels label_runs(const Grid& g, const RunTable& t);

// The bounding box of each component, voxel indices [lo, hi] (inclusive).
struct ComponentBox {
  Index3 lo, hi;
};
std::vector<ComponentBox> component_boxes(const Grid& g, const RunTable& t, const RunLabels& l);

// Calls visit(run index, row index j + ny*k, linear index of its first voxel) for every run, in
// parallel over slices.
template <class Visit>
void for_each_run(const Grid& g, const RunTable& t, Visit visit) {
  const std::int64_t nx = g.dims[0], ny = g.dims[1];
  parallel_for_chunks(g.dims[2], 4, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t r = k0 * ny; r < k1 * ny; ++r)
      for (std::int64_t n = t.row_start[r]; n < t.row_start[r + 1]; ++n)
        visit(n, r, static_cast<std::size_t>(r * nx + t.runs[n].begin));
  });
}

// Per component: whether any of its voxels satisfies `marked`.
template <class Marked>
std::vector<std::uint8_t> components_with(const Grid& g, const RunTable& t, const RunLabels& l,
                                          Marked marked) {
  std::vector<std::uint8_t> per_run(t.runs.size(), 0);
  for_each_run(g, t, [&](std::int64_t r, std::int64_t, std::size_t first) {
    for (std::int64_t i = 0; i < t.runs[r].end - t.runs[r].begin; ++i) {
      if (marked(first + static_cast<std::size_t>(i))) {
        per_run[r] = 1;
        break;
      }
    }
  });
  std::vector<std::uint8_t> result(l.voxels.size(), 0);
  for (std::size_t r = 0; r < per_run.size(); ++r)
    if (per_run[r]) result[l.of_run[r]] = 1;
  return result;
}

// Per component: the sum of value(linear index), an integer, over its voxels (each run summed in
// parallel over slices, then the runs summed per component in one thread: a component spans
// slices, so it never takes sums from two threads).
template <class Value>
std::vector<std::int64_t> sum_per_component(const Grid& g, const RunTable& t, const RunLabels& l,
                                            Value value) {
  std::vector<std::int64_t> per_run(t.runs.size(), 0);
  for_each_run(g, t, [&](std::int64_t r, std::int64_t, std::size_t first) {
    for (std::int64_t i = 0; i < t.runs[r].end - t.runs[r].begin; ++i)
      per_run[r] += value(first + static_cast<std::size_t>(i));
  });
  std::vector<std::int64_t> result(l.voxels.size(), 0);
  for (std::size_t r = 0; r < per_run.size(); ++r) result[l.of_run[r]] += per_run[r];
  return result;
}

// Per component: how many of its voxels satisfy `counted`.
template <class Counted>
std::vector<std::int64_t> count_per_component(const Grid& g, const RunTable& t, const RunLabels& l,
                                              Counted counted) {
  return sum_per_component(g, t, l, [&](std::size_t n) -> std::int64_t { return counted(n); });
}

// Whether any face neighbour of voxel n (linear index on g) satisfies pred(linear index).
template <class Pred>
bool any_face_neighbour(const Grid& g, std::size_t n, Pred pred) {
  const auto i = static_cast<std::int64_t>(n % static_cast<std::size_t>(g.dims[0]));
  const auto jk = static_cast<std::int64_t>(n / static_cast<std::size_t>(g.dims[0]));
  const std::int64_t j = jk % g.dims[1], k = jk / g.dims[1];
  const std::int64_t sy = g.dims[0], sz = g.dims[0] * g.dims[1];
  const auto m = static_cast<std::int64_t>(n);
  return (i > 0 && pred(m - 1)) || (i + 1 < g.dims[0] && pred(m + 1)) || (j > 0 && pred(m - sy)) ||
         (j + 1 < g.dims[1] && pred(m + sy)) || (k > 0 && pred(m - sz)) ||
         (k + 1 < g.dims[2] && pred(m + sz));
}

// Grows `mask` through face neighbours `allowed(linear index)` says yes to, until nothing more
// joins (a flood fill from all its voxels at once; allowed is asked once per voxel reached).
template <class Allowed>
void grow_within(Mask& mask, Allowed allowed) {
  const Grid& g = mask.grid;
  std::vector<std::size_t> front;
  for (std::size_t n = 0; n < mask.size(); ++n)
    if (mask.data[n]) front.push_back(n);
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const std::int64_t step[6] = {-1, 1, -nx, nx, -nx * ny, nx * ny};
  while (!front.empty()) {
    const auto m = static_cast<std::int64_t>(front.back());
    front.pop_back();
    const std::int64_t i = m % nx, j = (m / nx) % ny, k = m / (nx * ny);
    const bool inside[6] = {i > 0, i + 1 < nx, j > 0, j + 1 < ny, k > 0, k + 1 < nz};
    for (int d = 0; d < 6; ++d) {
      if (!inside[d]) continue;
      const auto o = static_cast<std::size_t>(m + step[d]);
      if (mask.data[o] || !allowed(o)) continue;
      mask.data[o] = 1;
      front.push_back(o);
    }
  }
}

// Writes `value(label)` over every run of the table.
template <class Value>
void rewrite_runs(const Grid& g, const RunTable& t, const RunLabels& l, Value value, Mask& mask) {
  for_each_run(g, t, [&](std::int64_t r, std::int64_t, std::size_t first) {
    std::fill_n(mask.data.begin() + static_cast<std::ptrdiff_t>(first),
                t.runs[r].end - t.runs[r].begin, static_cast<std::uint8_t>(value(l.of_run[r])));
  });
}

// Volume of one voxel in ml.
double voxel_ml(const Grid& g);

// Number of nonzero voxels.
std::uint64_t count_nonzero(const Mask& mask);

// Calls visit(linear index) for every nonzero voxel, in parallel over slices.
template <class Visit>
void for_each_nonzero(const Mask& mask, Visit visit) {
  const std::int64_t nx = mask.grid.dims[0], ny = mask.grid.dims[1];
  parallel_for_chunks(mask.grid.dims[2], 2, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t r = k0 * ny; r < k1 * ny; ++r) {
      const std::uint8_t* row = mask.data.data() + r * nx;
      for (std::int64_t i = next_byte(row, 0, nx, true); i < nx;
           i = next_byte(row, i + 1, nx, true))
        visit(static_cast<std::size_t>(r * nx + i));
    }
  });
}

// The linear indices of the nonzero voxels of `mask` that satisfy keep(linear index), in
// increasing order: each slice's list is filled by the one thread that visits that slice
// (for_each_nonzero shares slices out whole), then the lists are joined. For a stage whose few
// changes must wait until every voxel is judged, instead of a fresh grid-size mask of them.
template <class Keep>
std::vector<std::size_t> nonzero_where(const Mask& mask, Keep keep) {
  const auto slice = static_cast<std::size_t>(mask.grid.dims[0] * mask.grid.dims[1]);
  std::vector<std::vector<std::size_t>> per_slice(static_cast<std::size_t>(mask.grid.dims[2]));
  for_each_nonzero(mask, [&](std::size_t n) {
    if (keep(n)) per_slice[n / slice].push_back(n);
  });
  std::vector<std::size_t> all;
  for (const auto& list : per_slice) all.insert(all.end(), list.begin(), list.end());
  return all;
}

}  // namespace palp::segmentation
