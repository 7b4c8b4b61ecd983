// Run extraction and 3D labelling of masks (see components.hpp): a union-find over runs along i.
#include "prep/segment/components.hpp"

#include <algorithm>
#include <vector>

namespace palp::segmentation {
namespace {

// Appends the runs of nonzero (or zero) bytes of one row to `out`; returns how many.
std::int64_t scan_row(const std::uint8_t* row, std::int64_t n, bool zeros, std::vector<Run>& out) {
  std::int64_t count = 0;
  for (std::int64_t i = next_byte(row, 0, n, !zeros); i < n; i = next_byte(row, i, n, !zeros)) {
    const std::int64_t end = next_byte(row, i, n, zeros);
    out.push_back({i, end});
    ++count;
    i = end;
  }
  return count;
}

}  // namespace

void unite_touching(const std::vector<Run>& runs, std::int64_t a, std::int64_t a_end,
                    std::int64_t b, std::int64_t b_end, std::int64_t gap, DisjointSets& sets) {
  while (a < a_end && b < b_end) {
    if (runs[a].begin < runs[b].end + gap && runs[b].begin < runs[a].end + gap) sets.unite(a, b);
    if (runs[a].end < runs[b].end) {
      ++a;
    } else {
      ++b;
    }
  }
}

RunTable extract_runs(const Mask& mask, bool zeros) {
  const Grid& g = mask.grid;
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const std::uint8_t* data = mask.data.data();
  RunTable t;
  t.row_start.assign(static_cast<std::size_t>(ny * nz + 1), 0);
  // One scan of the mask: each slice's runs go to the slice's own list (a slice is visited by one
  // thread), which are then joined in slice order, the table a count pass and a fill pass made.
  std::vector<std::vector<Run>> per_slice(static_cast<std::size_t>(nz));
  parallel_for_chunks(nz, 4, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t k = k0; k < k1; ++k)
      for (std::int64_t r = k * ny; r < (k + 1) * ny; ++r)
        t.row_start[r + 1] = scan_row(data + r * nx, nx, zeros, per_slice[k]);
  });
  std::partial_sum(t.row_start.begin(), t.row_start.end(), t.row_start.begin());
  t.runs.resize(static_cast<std::size_t>(t.row_start.back()));
  parallel_for_chunks(nz, 4, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t k = k0; k < k1; ++k)
      std::copy(per_slice[k].begin(), per_slice[k].end(), t.runs.begin() + t.row_start[k * ny]);
  });
  return t;
}

RunLabels label_runs(const Grid& g, const RunTable& t) {
  const std::int64_t ny = g.dims[1], nz = g.dims[2];
  const auto& start = t.row_start;
  DisjointSets sets;
  sets.reset(t.runs.size());
  const auto unite_rows = [&](std::int64_t ra, std::int64_t rb) {
    unite_touching(t.runs, start[ra], start[ra + 1], start[rb], start[rb + 1], 0, sets);
  };
  // Within a slice only that slice's runs are touched, so slices unite in parallel.
  parallel_for_chunks(nz, 4, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t k = k0; k < k1; ++k)
      for (std::int64_t j = 1; j < ny; ++j) unite_rows(j - 1 + ny * k, j + ny * k);
  });
  for (std::int64_t k = 1; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j) unite_rows(j + ny * (k - 1), j + ny * k);
  RunLabels labels;
  labels.of_run.resize(t.runs.size());
  for (std::size_t r = 0; r < t.runs.size(); ++r) {
    const auto root = static_cast<std::size_t>(sets.find(static_cast<std::int64_t>(r)));
    if (root == r) {
      labels.of_run[r] = static_cast<std::int64_t>(labels.voxels.size());
      labels.voxels.push_back(0);
    } else {
      labels.of_run[r] = labels.of_run[root];
    }
    labels.voxels[labels.of_run[r]] += t.runs[r].end - t.runs[r].begin;
  }
  return labels;
}

std::vector<ComponentBox> component_boxes(const Grid& g, const RunTable& t, const RunLabels& l) {
  std::vector<ComponentBox> boxes(l.voxels.size(),
                                  ComponentBox{{g.dims[0], g.dims[1], g.dims[2]}, {-1, -1, -1}});
  for (std::int64_t row = 0; row < g.dims[1] * g.dims[2]; ++row)
    for (std::int64_t r = t.row_start[row]; r < t.row_start[row + 1]; ++r) {
      ComponentBox& b = boxes[static_cast<std::size_t>(l.of_run[r])];
      const Index3 first{t.runs[r].begin, row % g.dims[1], row / g.dims[1]};
      const Index3 last{t.runs[r].end - 1, first[1], first[2]};
      for (int axis = 0; axis < 3; ++axis) {
        b.lo[axis] = std::min(b.lo[axis], first[axis]);
        b.hi[axis] = std::max(b.hi[axis], last[axis]);
      }
    }
  return boxes;
}

double voxel_ml(const Grid& g) {
  return g.spacing[0] * g.spacing[1] * g.spacing[2] / 1000.0;
}

std::uint64_t count_nonzero(const Mask& mask) {
  // Byte counters per lane, emptied before they can overflow: the inner loop vectorizes to
  // byte compares and adds (std::count widens every byte to 64 bits; about 8x slower).
  constexpr std::size_t kLanes = 64, kBlock = kLanes * 255;
  const std::uint8_t* p = mask.data.data();
  std::size_t left = mask.data.size();
  std::uint64_t total = 0;
  for (; left >= kBlock; p += kBlock, left -= kBlock) {
    std::uint8_t lanes[kLanes] = {};
    for (std::size_t i = 0; i < kBlock; i += kLanes)
      for (std::size_t l = 0; l < kLanes; ++l) lanes[l] += p[i + l] != 0 ? 1 : 0;
    for (const std::uint8_t n : lanes) total += n;
  }
  for (std::size_t i = 0; i < left; ++i) total += p[i] != 0 ? 1 : 0;
  return total;
}

}  // namespace palp::segmentation
