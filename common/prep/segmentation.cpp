// Body and bone masks (see segmentation.hpp). Connected components work on runs of voxels along
// i with a union-find over runs; per-slice steps (table removal, cores, hole and marrow filling)
// run in parallel over slices. Mask rows are scanned eight bytes at a time where they are empty.
#include "prep/segmentation.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include "base/errors.hpp"
#include "base/parallel.hpp"

namespace palp {
namespace {

// ---------------------------------------------------------------------------------------------
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

// ---------------------------------------------------------------------------------------------
// Byte scanning: the first position at or after i in row[0, n) whose byte is nonzero (or zero).

bool has_zero_byte(std::uint64_t w) {
  return ((w - 0x0101010101010101ull) & ~w & 0x8080808080808080ull) != 0;
}

std::int64_t next_byte(const std::uint8_t* row, std::int64_t i, std::int64_t n, bool nonzero) {
  std::uint64_t w = 0;
  for (; i + 8 <= n; i += 8) {
    std::memcpy(&w, row + i, 8);
    if (nonzero ? w != 0 : has_zero_byte(w)) break;
  }
  while (i < n && (row[i] != 0) != nonzero) ++i;
  return i;
}

// Runs of nonzero (or zero) bytes of one row; returns how many, writing them to `out` if given.
std::int64_t scan_row(const std::uint8_t* row, std::int64_t n, bool zeros, Run* out) {
  std::int64_t count = 0;
  for (std::int64_t i = next_byte(row, 0, n, !zeros); i < n; i = next_byte(row, i, n, !zeros)) {
    const std::int64_t end = next_byte(row, i, n, zeros);
    if (out) out[count] = {i, end};
    ++count;
    i = end;
  }
  return count;
}

// ---------------------------------------------------------------------------------------------
// 3D connected components (6-connected) of a mask's nonzero (or zero) voxels, as runs along i.

struct RunTable {
  std::vector<Run> runs;
  std::vector<std::int64_t>
      row_start;  // row r = j + ny*k holds runs [row_start[r], row_start[r+1])
};

RunTable extract_runs(const Mask& mask, bool zeros) {
  const Grid& g = mask.grid;
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const std::uint8_t* data = mask.data.data();
  RunTable t;
  t.row_start.assign(static_cast<std::size_t>(ny * nz + 1), 0);
  parallel_for_chunks(nz, 4, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t r = k0 * ny; r < k1 * ny; ++r)
      t.row_start[r + 1] = scan_row(data + r * nx, nx, zeros, nullptr);
  });
  std::partial_sum(t.row_start.begin(), t.row_start.end(), t.row_start.begin());
  t.runs.resize(static_cast<std::size_t>(t.row_start.back()));
  parallel_for_chunks(nz, 4, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t r = k0 * ny; r < k1 * ny; ++r)
      scan_row(data + r * nx, nx, zeros, t.runs.data() + t.row_start[r]);
  });
  return t;
}

struct RunLabels {
  std::vector<std::int64_t> of_run;  // component of each run
  std::vector<std::int64_t> voxels;  // voxel count of each component
};

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

// Writes `value(label)` over every run of the table.
template <class Value>
void rewrite_runs(const Grid& g, const RunTable& t, const RunLabels& l, Value value, Mask& mask) {
  for_each_run(g, t, [&](std::int64_t r, std::int64_t, std::size_t first) {
    std::fill_n(mask.data.begin() + static_cast<std::ptrdiff_t>(first),
                t.runs[r].end - t.runs[r].begin, static_cast<std::uint8_t>(value(l.of_run[r])));
  });
}

double voxel_ml(const Grid& g) {
  return g.spacing[0] * g.spacing[1] * g.spacing[2] / 1000.0;
}

std::uint64_t count_nonzero(const Mask& mask) {
  return static_cast<std::uint64_t>(mask.data.size() - static_cast<std::size_t>(std::count(
                                                           mask.data.begin(), mask.data.end(), 0)));
}

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

// ---------------------------------------------------------------------------------------------
// Slices as 2D planes.

std::int64_t axis_stride(const Grid& g, int axis) {
  return axis == 0 ? 1 : axis == 1 ? g.dims[0] : g.dims[0] * g.dims[1];
}

// Voxel (u, v) of one slice sits at base + u*su + v*sv.
struct Plane {
  std::int64_t nu = 0, nv = 0;
  std::int64_t base = 0, su = 0, sv = 0;
  double u_mm = 1.0, v_mm = 1.0;
  std::size_t at(std::int64_t u, std::int64_t v) const {
    return static_cast<std::size_t>(base + u * su + v * sv);
  }
};

// Axial slice `s`: u runs across the patient, v runs from the back (v = 0, the table side)
// toward the front.
Plane axial_plane(const Grid& g, const PatientAxes& axes, std::int64_t s) {
  Plane p;
  p.nu = g.dims[axes.lateral];
  p.nv = g.dims[axes.posterior];
  p.su = axis_stride(g, axes.lateral);
  p.sv = axis_stride(g, axes.posterior);
  p.u_mm = g.spacing[axes.lateral];
  p.v_mm = g.spacing[axes.posterior];
  p.base = s * axis_stride(g, axes.slice);
  if (axes.posterior_increasing) {
    p.base += (p.nv - 1) * p.sv;
    p.sv = -p.sv;
  }
  return p;
}

// Coronal slice `s` (across the posterior axis): u runs across the patient, v along the slices.
Plane coronal_plane(const Grid& g, const PatientAxes& axes, std::int64_t s) {
  Plane p;
  p.nu = g.dims[axes.lateral];
  p.nv = g.dims[axes.slice];
  p.su = axis_stride(g, axes.lateral);
  p.sv = axis_stride(g, axes.slice);
  p.u_mm = g.spacing[axes.lateral];
  p.v_mm = g.spacing[axes.slice];
  p.base = s * axis_stride(g, axes.posterior);
  return p;
}

// Runs of one plane along u, row by row in v.
struct PlaneRuns {
  std::vector<Run> runs;
  std::vector<std::int64_t> row_start;
};

// Runs of the nonzero (or zero) voxels of `mask` in the plane.
void scan_plane(const Plane& p, const std::uint8_t* mask, bool zeros, PlaneRuns& out) {
  out.runs.clear();
  out.row_start.assign(static_cast<std::size_t>(p.nv + 1), 0);
  for (std::int64_t v = 0; v < p.nv; ++v) {
    if (p.su == 1) {
      const std::uint8_t* row = mask + p.at(0, v);
      for (std::int64_t u = next_byte(row, 0, p.nu, !zeros); u < p.nu;
           u = next_byte(row, u, p.nu, !zeros)) {
        const std::int64_t end = next_byte(row, u, p.nu, zeros);
        out.runs.push_back({u, end});
        u = end;
      }
    } else {
      for (std::int64_t u = 0; u < p.nu;) {
        if ((mask[p.at(u, v)] == 0) != zeros) {
          ++u;
          continue;
        }
        const std::int64_t begin = u;
        while (u < p.nu && (mask[p.at(u, v)] == 0) == zeros) ++u;
        out.runs.push_back({begin, u});
      }
    }
    out.row_start[v + 1] = static_cast<std::int64_t>(out.runs.size());
  }
}

// Reusable buffers for the per-slice steps of one thread.
struct PlaneScratch {
  PlaneRuns runs;
  DisjointSets sets;
  std::vector<std::uint8_t> flags;
  std::vector<std::int64_t> area;
  std::vector<std::uint8_t> cells, tmp, closed, marrow;
  std::vector<std::int64_t> counts;
};

// Labels the zeros of `mask` in one plane (4-connected) and flags (s.flags[root] = 1) the regions
// that reach the plane's edge; s.area[root] gets each region's size.
void label_plane_background(const Plane& p, const std::uint8_t* mask, PlaneScratch& s) {
  scan_plane(p, mask, true, s.runs);
  const auto& runs = s.runs.runs;
  const auto& start = s.runs.row_start;
  s.sets.reset(runs.size());
  for (std::int64_t v = 1; v < p.nv; ++v)
    unite_touching(runs, start[v - 1], start[v], start[v], start[v + 1], 0, s.sets);
  s.flags.assign(runs.size(), 0);
  s.area.assign(runs.size(), 0);
  for (std::int64_t v = 0; v < p.nv; ++v) {
    for (std::int64_t r = start[v]; r < start[v + 1]; ++r) {
      const std::int64_t root = s.sets.find(r);
      if (v == 0 || v == p.nv - 1 || runs[r].begin == 0 || runs[r].end == p.nu) s.flags[root] = 1;
      s.area[root] += runs[r].end - runs[r].begin;
    }
  }
}

// Fills the holes of `mask` in one plane — 4-connected regions of zeros that do not reach the
// plane's edge — whose area (voxels) satisfies accept(area).
template <class Accept>
void fill_plane_holes(const Plane& p, std::uint8_t* mask, Accept accept, PlaneScratch& s) {
  label_plane_background(p, mask, s);
  for (std::int64_t v = 0; v < p.nv; ++v) {
    for (std::int64_t r = s.runs.row_start[v]; r < s.runs.row_start[v + 1]; ++r) {
      const std::int64_t root = s.sets.find(r);
      if (s.flags[root] || !accept(s.area[root])) continue;
      for (std::int64_t u = s.runs.runs[r].begin; u < s.runs.runs[r].end; ++u) mask[p.at(u, v)] = 1;
    }
  }
}

// Sets s.cells[u + nu*v] = 1 for the zeros of `mask` that are 4-connected to the plane's edge.
void mark_outside_air(const Plane& p, const std::uint8_t* mask, PlaneScratch& s) {
  label_plane_background(p, mask, s);
  s.cells.assign(static_cast<std::size_t>(p.nu * p.nv), 0);
  for (std::int64_t v = 0; v < p.nv; ++v) {
    for (std::int64_t r = s.runs.row_start[v]; r < s.runs.row_start[v + 1]; ++r) {
      if (!s.flags[s.sets.find(r)]) continue;
      const Run& run = s.runs.runs[r];
      std::fill(s.cells.begin() + run.begin + p.nu * v, s.cells.begin() + run.end + p.nu * v, 1);
    }
  }
}

// Marks with 2 the voxels of `mask` whose box neighbourhood (half sizes ru, rv) is all nonzero.
void mark_plane_cores(const Plane& p, std::uint8_t* mask, std::int64_t ru, std::int64_t rv,
                      PlaneScratch& s) {
  s.cells.assign(static_cast<std::size_t>(p.nu * p.nv), 0);
  scan_plane(p, mask, false, s.runs);
  for (std::int64_t v = 0; v < p.nv; ++v) {
    for (std::int64_t r = s.runs.row_start[v]; r < s.runs.row_start[v + 1]; ++r) {
      for (std::int64_t u = s.runs.runs[r].begin + ru; u < s.runs.runs[r].end - ru; ++u)
        s.cells[u + p.nu * v] = 1;
    }
  }
  s.counts.assign(static_cast<std::size_t>(p.nu), 0);  // consecutive rows kept, per column
  for (std::int64_t v = 0; v < p.nv; ++v) {
    for (std::int64_t u = 0; u < p.nu; ++u) {
      auto& c = s.counts[u];
      c = s.cells[u + p.nu * v] ? c + 1 : 0;
      if (c >= 2 * rv + 1) mask[p.at(u, v - rv)] = 2;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Table removal in one axial slice. Walking each column from the back, the runs of "not air" met
// before the patient are candidates: thin (<= max thickness) and with outside air in front (a
// posterior chest wall has the enclosed lung in front of it; a run that fails either test is the
// patient). Candidates that join (8-connected) into a band wide enough are table. Where a pad
// touches the patient, the band is followed under the patient along its interpolated top and
// bottom.

struct ColumnRun {
  std::int64_t u, v0, v1;  // rows [v0, v1) of column u
};

struct TableScratch {
  std::vector<std::int64_t> open;  // start of the run being read in each column, -1 if none
  std::vector<std::uint8_t> blocked;
  std::vector<ColumnRun> thick;  // first thick run of each column (v0 = -1: none)
  std::vector<ColumnRun> candidates;
  std::vector<std::int64_t> column_start;
  DisjointSets sets;
  PlaneScratch air;  // outside air of the slice, in air.cells
  std::vector<std::int64_t> u_min, u_max, voxels;
  std::vector<std::uint8_t> valid;  // per candidate: part of a band
  std::vector<ColumnRun> band;      // anterior-most band run of each column (v0 = -1: none)
};

struct TableLimits {
  std::int64_t max_thickness;  // voxels along v
  double min_width_mm;
  std::int64_t tolerance;  // voxels along v, for following a band under the patient
};

void read_columns(const Plane& p, const std::uint8_t* mask, const TableLimits& lim,
                  TableScratch& s) {
  s.open.assign(static_cast<std::size_t>(p.nu), -1);
  s.blocked.assign(static_cast<std::size_t>(p.nu), 0);
  s.thick.assign(static_cast<std::size_t>(p.nu), ColumnRun{0, -1, -1});
  s.candidates.clear();
  mark_outside_air(p, mask, s.air);
  const auto close = [&](std::int64_t u, std::int64_t v0, std::int64_t v1) {
    if (s.blocked[u]) return;
    const bool outside_in_front = v1 == p.nv || s.air.cells[u + p.nu * v1];
    if (v1 - v0 > lim.max_thickness || !outside_in_front) {
      s.blocked[u] = 1;
      s.thick[u] = {u, v0, v1};
    } else {
      s.candidates.push_back({u, v0, v1});
    }
  };
  for (std::int64_t v = 0; v <= p.nv; ++v) {
    for (std::int64_t u = 0; u < p.nu; ++u) {
      const bool on = v < p.nv && mask[p.at(u, v)] != 0;
      if (on && s.open[u] < 0) s.open[u] = v;
      if (!on && s.open[u] >= 0) {
        close(u, s.open[u], v);
        s.open[u] = -1;
      }
    }
  }
  std::sort(s.candidates.begin(), s.candidates.end(), [](const ColumnRun& a, const ColumnRun& b) {
    return a.u != b.u ? a.u < b.u : a.v0 < b.v0;
  });
}

// Groups the candidates into 8-connected bands and records the valid ones per column.
void find_bands(const Plane& p, const TableLimits& lim, TableScratch& s) {
  const auto& c = s.candidates;
  s.column_start.assign(static_cast<std::size_t>(p.nu + 1), 0);
  for (const ColumnRun& r : c) ++s.column_start[r.u + 1];
  std::partial_sum(s.column_start.begin(), s.column_start.end(), s.column_start.begin());
  s.sets.reset(c.size());
  for (std::int64_t u = 1; u < p.nu; ++u) {
    std::int64_t a = s.column_start[u - 1], b = s.column_start[u];
    const std::int64_t a_end = s.column_start[u], b_end = s.column_start[u + 1];
    while (a < a_end && b < b_end) {
      if (c[a].v0 <= c[b].v1 && c[b].v0 <= c[a].v1) s.sets.unite(a, b);
      if (c[a].v1 < c[b].v1) {
        ++a;
      } else {
        ++b;
      }
    }
  }
  s.u_min.assign(c.size(), p.nu);
  s.u_max.assign(c.size(), -1);
  s.voxels.assign(c.size(), 0);
  for (std::size_t r = 0; r < c.size(); ++r) {
    const auto root = static_cast<std::size_t>(s.sets.find(static_cast<std::int64_t>(r)));
    s.u_min[root] = std::min(s.u_min[root], c[r].u);
    s.u_max[root] = std::max(s.u_max[root], c[r].u);
    s.voxels[root] += c[r].v1 - c[r].v0;
  }
  s.band.assign(static_cast<std::size_t>(p.nu), ColumnRun{0, -1, -1});
  s.valid.assign(c.size(), 0);
  for (std::size_t r = 0; r < c.size(); ++r) {
    const auto root = static_cast<std::size_t>(s.sets.find(static_cast<std::int64_t>(r)));
    const double columns = static_cast<double>(s.u_max[root] - s.u_min[root] + 1);
    const double width_mm = columns * p.u_mm;
    const double thickness_mm = static_cast<double>(s.voxels[root]) / columns * p.v_mm;
    s.valid[r] = width_mm >= lim.min_width_mm && width_mm >= 2.0 * thickness_mm;
    if (s.valid[r]) s.band[c[r].u] = c[r];  // candidates run back to front: the last is on top
  }
}

// Clears every voxel of the valid bands; returns how many.
std::uint64_t clear_bands(const Plane& p, std::uint8_t* mask, const TableScratch& s) {
  std::uint64_t cleared = 0;
  for (std::size_t r = 0; r < s.candidates.size(); ++r) {
    if (!s.valid[r]) continue;
    const ColumnRun& run = s.candidates[r];
    for (std::int64_t v = run.v0; v < run.v1; ++v) mask[p.at(run.u, v)] = 0;
    cleared += static_cast<std::uint64_t>(run.v1 - run.v0);
  }
  return cleared;
}

// Under the patient, a pad that touches the back merges with the body into one thick run. From
// each side of such a stretch of columns the band is followed inward while the column's thick run
// starts where the interpolated band bottom is; the rows up to the interpolated band top are
// cleared.
std::uint64_t follow_bands_under_patient(const Plane& p, std::uint8_t* mask, const TableLimits& lim,
                                         const TableScratch& s) {
  std::uint64_t cleared = 0;
  const auto has_band = [&](std::int64_t u) { return s.band[u].v0 >= 0; };
  std::vector<std::uint8_t> done(static_cast<std::size_t>(p.nu), 0);
  for (std::int64_t left = 0; left < p.nu;) {
    if (has_band(left)) {
      ++left;
      continue;
    }
    std::int64_t right = left;
    while (right + 1 < p.nu && !has_band(right + 1)) ++right;
    const bool from_left = left > 0, from_right = right + 1 < p.nu;
    const ColumnRun a = from_left ? s.band[left - 1] : s.band[right + 1];
    const ColumnRun b = from_right ? s.band[right + 1] : s.band[left - 1];
    const auto slab = [&](std::int64_t u) {
      const double t = (from_left && from_right) ? static_cast<double>(u - left + 1) /
                                                       static_cast<double>(right - left + 2)
                                                 : 0.0;
      return std::pair<std::int64_t, std::int64_t>{
          std::llround(static_cast<double>(a.v0) + t * static_cast<double>(b.v0 - a.v0)),
          std::llround(static_cast<double>(a.v1) + t * static_cast<double>(b.v1 - a.v1))};
    };
    const auto absorb = [&](std::int64_t u, ColumnRun& previous) {
      const ColumnRun& run = s.thick[u];
      const auto [bottom, top] = slab(u);
      if (done[u] || run.v0 < 0 || std::abs(run.v0 - bottom) > lim.tolerance) return false;
      if (run.v1 < top || top <= run.v0) return false;
      if (run.v0 > previous.v1 || previous.v0 > top) return false;
      for (std::int64_t v = run.v0; v < top; ++v) mask[p.at(u, v)] = 0;
      cleared += static_cast<std::uint64_t>(top - run.v0);
      done[u] = 1;
      previous = {u, run.v0, top};
      return true;
    };
    if (from_left) {
      ColumnRun previous = s.band[left - 1];
      for (std::int64_t u = left; u <= right; ++u)
        if (!absorb(u, previous)) break;
    }
    if (from_right) {
      ColumnRun previous = s.band[right + 1];
      for (std::int64_t u = right; u >= left; --u)
        if (!absorb(u, previous)) break;
    }
    left = right + 1;
  }
  return cleared;
}

std::uint64_t remove_table_in_plane(const Plane& p, std::uint8_t* mask, const TableLimits& lim,
                                    TableScratch& s) {
  read_columns(p, mask, lim, s);
  find_bands(p, lim, s);
  const std::uint64_t cleared = clear_bands(p, mask, s);
  return cleared + follow_bands_under_patient(p, mask, lim, s);
}

// ---------------------------------------------------------------------------------------------
// Body steps

void check_params(const SegmentationParams& p) {
  const double values[] = {
      p.body_threshold_hu,      p.min_body_part_ml,           p.body_core_radius_mm,
      p.max_table_thickness_mm, p.min_table_width_mm,         p.bone_seed_hu,
      p.bone_grow_hu,           p.bone_leak_contact_fraction, p.marrow_min_hu,
      p.bone_small_hole_mm2,    p.bone_max_cavity_ml,         p.min_bone_island_ml};
  for (double v : values)
    if (!std::isfinite(v)) throw UsageError("segmentation: parameters must be finite numbers");
  if (p.min_body_part_ml < 0 || p.body_core_radius_mm < 0 || p.max_table_thickness_mm < 0 ||
      p.min_table_width_mm < 0 || p.bone_leak_contact_fraction < 0 || p.bone_small_hole_mm2 < 0 ||
      p.bone_max_cavity_ml < 0 || p.min_bone_island_ml < 0)
    throw UsageError("segmentation: sizes, radii and fractions must not be negative");
  if (p.bone_grow_hu > p.bone_seed_hu)
    throw UsageError("segmentation: bone_grow_hu must not exceed bone_seed_hu");
}

// HU stored as integers: hu > threshold exactly when hu > floor(threshold).
int integer_floor(double hu) {
  return static_cast<int>(std::clamp(std::floor(hu), -40000.0, 40000.0));
}

Mask threshold_above(const CtVolume& ct, double threshold_hu) {
  Mask mask(ct.grid, 0, "body mask");
  const std::int64_t n = static_cast<std::int64_t>(ct.size());
  const int limit = integer_floor(threshold_hu);
  parallel_for_chunks(n, 1 << 20, [&](std::int64_t b, std::int64_t e) {
    for (std::int64_t i = b; i < e; ++i) mask.data[i] = ct.data[i] > limit;
  });
  return mask;
}

std::uint64_t remove_table(const PatientAxes& axes, const SegmentationParams& params, Mask& mask) {
  const Grid& g = mask.grid;
  const double v_mm = g.spacing[axes.posterior];
  const TableLimits lim{static_cast<std::int64_t>(std::floor(params.max_table_thickness_mm / v_mm)),
                        params.min_table_width_mm,
                        std::max<std::int64_t>(1, std::llround(2.0 / v_mm))};
  std::vector<std::uint64_t> cleared(static_cast<std::size_t>(g.dims[axes.slice]), 0);
  parallel_for_chunks(g.dims[axes.slice], 2, [&](std::int64_t s0, std::int64_t s1) {
    TableScratch scratch;
    for (std::int64_t s = s0; s < s1; ++s)
      cleared[s] = remove_table_in_plane(axial_plane(g, axes, s), mask.data.data(), lim, scratch);
  });
  return std::accumulate(cleared.begin(), cleared.end(), std::uint64_t{0});
}

void mark_cores(const PatientAxes& axes, double radius_mm, Mask& mask) {
  const Grid& g = mask.grid;
  const auto ru = static_cast<std::int64_t>(std::floor(radius_mm / g.spacing[axes.lateral]));
  const auto rv = static_cast<std::int64_t>(std::floor(radius_mm / g.spacing[axes.posterior]));
  parallel_for_chunks(g.dims[axes.slice], 2, [&](std::int64_t s0, std::int64_t s1) {
    PlaneScratch scratch;
    for (std::int64_t s = s0; s < s1; ++s)
      mark_plane_cores(axial_plane(g, axes, s), mask.data.data(), ru, rv, scratch);
  });
}

// Keeps the 3D parts (6-connected) that are large enough and hold a core voxel (value 2).
void keep_patient_parts(double min_part_ml, Mask& mask) {
  const Grid& g = mask.grid;
  const RunTable runs = extract_runs(mask, false);
  const RunLabels labels = label_runs(g, runs);
  const auto has_core =
      components_with(g, runs, labels, [&](std::size_t n) { return mask.data[n] == 2; });
  const double ml = voxel_ml(g);
  // The largest cored part is the patient and always stays, however small the scan.
  std::int64_t largest = -1;
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(labels.voxels.size()); ++c) {
    if (has_core[c] && (largest < 0 || labels.voxels[c] > labels.voxels[largest])) largest = c;
  }
  rewrite_runs(
      g, runs, labels,
      [&](std::int64_t c) {
        return has_core[c] &&
               (c == largest || static_cast<double>(labels.voxels[c]) * ml >= min_part_ml);
      },
      mask);
}

void fill_axial_holes(const PatientAxes& axes, Mask& mask) {
  const Grid& g = mask.grid;
  parallel_for_chunks(g.dims[axes.slice], 2, [&](std::int64_t s0, std::int64_t s1) {
    PlaneScratch scratch;
    for (std::int64_t s = s0; s < s1; ++s) {
      fill_plane_holes(
          axial_plane(g, axes, s), mask.data.data(), [](std::int64_t) { return true; }, scratch);
    }
  });
}

// ---------------------------------------------------------------------------------------------
// Bone steps. Values while growing: 2 = seed, 1 = grown voxel below the seed level.

Mask bone_candidates(const CtVolume& ct, const Mask& body, const SegmentationParams& params) {
  Mask bone(ct.grid, 0, "bone mask");
  const std::int64_t n = static_cast<std::int64_t>(ct.size());
  const int grow = integer_floor(std::ceil(params.bone_grow_hu));
  const int seed = integer_floor(std::ceil(params.bone_seed_hu));
  parallel_for_chunks(n, 1 << 20, [&](std::int64_t b, std::int64_t e) {
    for (std::int64_t i = b; i < e; ++i) {
      const int hu = ct.data[i];
      bone.data[i] = static_cast<std::uint8_t>(body.data[i] ? (hu >= seed) + (hu >= grow) : 0);
    }
  });
  return bone;
}

// Region growing: the candidate regions (6-connected) that hold a seed, values kept.
void keep_seeded_regions(Mask& bone) {
  const Grid& g = bone.grid;
  const RunTable runs = extract_runs(bone, false);
  const RunLabels labels = label_runs(g, runs);
  const auto seeded =
      components_with(g, runs, labels, [&](std::size_t n) { return bone.data[n] == 2; });
  for_each_run(g, runs, [&](std::int64_t r, std::int64_t, std::size_t first) {
    if (seeded[labels.of_run[r]]) return;
    std::fill_n(bone.data.begin() + static_cast<std::ptrdiff_t>(first),
                runs.runs[r].end - runs.runs[r].begin, std::uint8_t{0});
  });
}

// Whether any face neighbour of voxel n satisfies `pred`.
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

// Leak removal: the grown voxels below the seed level that are not next to a seed form pieces;
// a piece that touches the seeds' rim with fewer than `fraction` of its voxels hangs on the bone by
// a narrow contact — a contrast-filled vessel or an enhancing organ — and is dropped.
void remove_leaks(double fraction, Mask& bone) {
  const Grid& g = bone.grid;
  const auto is_seed = [&](std::int64_t m) { return bone.data[m] == 2; };
  Mask piece(g, 0, "bone leak check");
  for_each_nonzero(bone, [&](std::size_t n) {
    if (bone.data[n] == 1 && !any_face_neighbour(g, n, is_seed)) piece.data[n] = 1;
  });
  const RunTable runs = extract_runs(piece, false);
  const RunLabels labels = label_runs(g, runs);
  const auto is_rim = [&](std::int64_t m) { return bone.data[m] == 1 && !piece.data[m]; };
  std::vector<std::int64_t> contact_per_run(runs.runs.size(), 0);
  for_each_run(g, runs, [&](std::int64_t r, std::int64_t, std::size_t first) {
    for (std::int64_t i = 0; i < runs.runs[r].end - runs.runs[r].begin; ++i)
      if (any_face_neighbour(g, first + static_cast<std::size_t>(i), is_rim)) ++contact_per_run[r];
  });
  std::vector<std::int64_t> contact(labels.voxels.size(), 0);
  for (std::size_t r = 0; r < runs.runs.size(); ++r)
    contact[labels.of_run[r]] += contact_per_run[r];
  for_each_run(g, runs, [&](std::int64_t r, std::int64_t, std::size_t first) {
    const std::int64_t c = labels.of_run[r];
    if (static_cast<double>(contact[c]) >= fraction * static_cast<double>(labels.voxels[c])) return;
    std::fill_n(bone.data.begin() + static_cast<std::ptrdiff_t>(first),
                runs.runs[r].end - runs.runs[r].begin, std::uint8_t{0});
  });
}

// 3-wide dilation (or erosion) of a 0/1 image of nu x nv, along rows or along columns. Outside the
// image counts as 0 when dilating and as 1 when eroding, so a closing contains its input.
void widen_rows(const std::uint8_t* in, std::uint8_t* out, std::int64_t nu, std::int64_t nv,
                bool dilate) {
  for (std::int64_t v = 0; v < nv; ++v) {
    const std::uint8_t* a = in + v * nu;
    std::uint8_t* o = out + v * nu;
    if (nu == 1) {
      o[0] = a[0];
      continue;
    }
    if (dilate) {
      o[0] = a[0] | a[1];
      for (std::int64_t u = 1; u + 1 < nu; ++u) o[u] = a[u - 1] | a[u] | a[u + 1];
      o[nu - 1] = a[nu - 2] | a[nu - 1];
    } else {
      o[0] = a[0] & a[1];
      for (std::int64_t u = 1; u + 1 < nu; ++u) o[u] = a[u - 1] & a[u] & a[u + 1];
      o[nu - 1] = a[nu - 2] & a[nu - 1];
    }
  }
}

void widen_columns(const std::uint8_t* in, std::uint8_t* out, std::int64_t nu, std::int64_t nv,
                   bool dilate) {
  for (std::int64_t v = 0; v < nv; ++v) {
    const std::uint8_t* mid = in + v * nu;
    std::uint8_t* o = out + v * nu;
    std::copy(mid, mid + nu, o);
    for (const std::int64_t w : {v - 1, v + 1}) {
      if (w < 0 || w >= nv) continue;
      const std::uint8_t* other = in + w * nu;
      if (dilate) {
        for (std::int64_t u = 0; u < nu; ++u) o[u] |= other[u];
      } else {
        for (std::int64_t u = 0; u < nu; ++u) o[u] &= other[u];
      }
    }
  }
}

void close_3x3(PlaneScratch& s, std::int64_t nu, std::int64_t nv) {
  s.tmp.resize(s.cells.size());
  s.closed.resize(s.cells.size());
  widen_rows(s.cells.data(), s.tmp.data(), nu, nv, true);
  widen_columns(s.tmp.data(), s.closed.data(), nu, nv, true);
  widen_rows(s.closed.data(), s.tmp.data(), nu, nv, false);
  widen_columns(s.tmp.data(), s.closed.data(), nu, nv, false);
}

// The box [u0, u1] x [v0, v1] of a plane that holds its nonzero voxels plus a margin; false if
// the plane has none.
struct Box2 {
  std::int64_t u0, u1, v0, v1;
};

bool nonzero_box(const Plane& p, const std::uint8_t* mask, std::int64_t margin, Box2& box) {
  box = {p.nu, -1, p.nv, -1};
  for (std::int64_t v = 0; v < p.nv; ++v) {
    std::int64_t first = -1, last = -1;
    if (p.su == 1) {
      const std::uint8_t* row = mask + p.at(0, v);
      first = next_byte(row, 0, p.nu, true);
      if (first == p.nu) continue;
      last = first;
      for (std::int64_t u = next_byte(row, first, p.nu, true); u < p.nu;
           u = next_byte(row, u + 1, p.nu, true))
        last = u;
    } else {
      for (std::int64_t u = 0; u < p.nu; ++u) {
        if (!mask[p.at(u, v)]) continue;
        if (first < 0) first = u;
        last = u;
      }
      if (first < 0) continue;
    }
    box = {std::min(box.u0, first), std::max(box.u1, last), std::min(box.v0, v), v};
  }
  if (box.u1 < 0) return false;
  box = {std::max<std::int64_t>(0, box.u0 - margin), std::min(p.nu - 1, box.u1 + margin),
         std::max<std::int64_t>(0, box.v0 - margin), std::min(p.nv - 1, box.v1 + margin)};
  return true;
}

// Marrow in one slice, worked on a copy of the bone's box. The bone is closed 3x3 (bridging the
// gaps of thin cortices); in each hole of the closed bone the voxels at or above marrow_min_hu are
// marrow (all of a small hole), so a canal the closing merges with a vertebral body stays open;
// the closing's own voxels join where they border marrow; small holes left inside are filled.
void fill_plane_marrow(const Plane& p, std::uint8_t* bone, const std::int16_t* hu,
                       const SegmentationParams& params, PlaneScratch& s) {
  Box2 box{};
  if (!nonzero_box(p, bone, 2, box)) return;
  const std::int64_t nu = box.u1 - box.u0 + 1, nv = box.v1 - box.v0 + 1;
  const auto at = [&](std::int64_t u, std::int64_t v) { return p.at(box.u0 + u, box.v0 + v); };
  const double pixel_mm2 = p.u_mm * p.v_mm;
  const auto small = [&](std::int64_t area) {
    return static_cast<double>(area) * pixel_mm2 <= params.bone_small_hole_mm2;
  };
  s.cells.resize(static_cast<std::size_t>(nu * nv));
  for (std::int64_t v = 0; v < nv; ++v)
    for (std::int64_t u = 0; u < nu; ++u) s.cells[u + nu * v] = bone[at(u, v)] != 0;
  close_3x3(s, nu, nv);
  const Plane local{nu, nv, 0, 1, nu, p.u_mm, p.v_mm};
  label_plane_background(local, s.closed.data(), s);
  s.marrow.assign(s.cells.size(), 0);
  for (std::int64_t v = 0; v < nv; ++v)
    for (std::int64_t r = s.runs.row_start[v]; r < s.runs.row_start[v + 1]; ++r) {
      const std::int64_t root = s.sets.find(r);
      if (s.flags[root]) continue;
      const bool whole = small(s.area[root]);
      for (std::int64_t u = s.runs.runs[r].begin; u < s.runs.runs[r].end; ++u)
        if (whole || hu[at(u, v)] >= params.marrow_min_hu) s.marrow[u + nu * v] = 1;
    }
  const auto marrow = [&](std::int64_t u, std::int64_t v) {
    return u >= 0 && v >= 0 && u < nu && v < nv && s.marrow[u + nu * v];
  };
  for (std::int64_t v = 0; v < nv; ++v)
    for (std::int64_t u = 0; u < nu; ++u) {
      auto& c = s.cells[u + nu * v];
      if (s.marrow[u + nu * v]) c = 1;
      if (!s.closed[u + nu * v] || c) continue;
      if (marrow(u - 1, v) || marrow(u + 1, v) || marrow(u, v - 1) || marrow(u, v + 1)) c = 1;
    }
  fill_plane_holes(local, s.cells.data(), small, s);
  for (std::int64_t v = 0; v < nv; ++v)
    for (std::int64_t u = 0; u < nu; ++u)
      if (s.cells[u + nu * v]) bone[at(u, v)] = 1;
}

// Marrow filling in axial slices, then in coronal ones (where a vertebral body is a ring of
// endplates and lateral walls even when its posterior wall is open at the basivertebral foramen).
void fill_marrow(const CtVolume& ct, const PatientAxes& axes, const SegmentationParams& params,
                 Mask& bone) {
  const Grid& g = bone.grid;
  parallel_for_chunks(g.dims[axes.slice], 2, [&](std::int64_t s0, std::int64_t s1) {
    PlaneScratch scratch;
    for (std::int64_t s = s0; s < s1; ++s)
      fill_plane_marrow(axial_plane(g, axes, s), bone.data.data(), ct.data.data(), params, scratch);
  });
  parallel_for_chunks(g.dims[axes.posterior], 2, [&](std::int64_t s0, std::int64_t s1) {
    PlaneScratch scratch;
    for (std::int64_t s = s0; s < s1; ++s)
      fill_plane_marrow(coronal_plane(g, axes, s), bone.data.data(), ct.data.data(), params,
                        scratch);
  });
}

// Cavities: regions outside the bone (6-connected) that do not reach the volume's border and hold
// at most max_ml are enclosed marrow and are filled.
void fill_enclosed_cavities(double max_ml, Mask& bone) {
  const Grid& g = bone.grid;
  const RunTable runs = extract_runs(bone, true);
  const RunLabels labels = label_runs(g, runs);
  std::vector<std::uint8_t> open(labels.voxels.size(), 0);
  const std::int64_t ny = g.dims[1], nz = g.dims[2];
  for (std::int64_t row = 0; row < ny * nz; ++row) {
    const std::int64_t j = row % ny, k = row / ny;
    const bool border_row = j == 0 || j == ny - 1 || k == 0 || k == nz - 1;
    for (std::int64_t r = runs.row_start[row]; r < runs.row_start[row + 1]; ++r)
      if (border_row || runs.runs[r].begin == 0 || runs.runs[r].end == g.dims[0])
        open[labels.of_run[r]] = 1;
  }
  const double ml = voxel_ml(g);
  for_each_run(g, runs, [&](std::int64_t r, std::int64_t, std::size_t first) {
    const std::int64_t c = labels.of_run[r];
    if (open[c] || static_cast<double>(labels.voxels[c]) * ml > max_ml) return;
    std::fill_n(bone.data.begin() + static_cast<std::ptrdiff_t>(first),
                runs.runs[r].end - runs.runs[r].begin, std::uint8_t{1});
  });
}

// Surface refinement: a bone voxel with a face neighbour outside the bone stays bone only if its
// HU reaches halfway between its brightest bone neighbour and the mean of its outside neighbours —
// the half-maximum edge, where partial volume puts the true surface.
void refine_surface(const CtVolume& ct, Mask& bone) {
  const Grid& g = bone.grid;
  Mask trim(g, 0, "bone surface");
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const std::int64_t steps[6] = {-1, 1, -nx, nx, -nx * ny, nx * ny};
  for_each_nonzero(bone, [&](std::size_t n) {
    const auto i = static_cast<std::int64_t>(n % static_cast<std::size_t>(nx));
    const auto jk = static_cast<std::int64_t>(n / static_cast<std::size_t>(nx));
    const std::int64_t j = jk % ny, k = jk / ny;
    const bool inside[6] = {i > 0, i + 1 < nx, j > 0, j + 1 < ny, k > 0, k + 1 < nz};
    double bright = -1e9, outside_sum = 0.0;
    int outside = 0;
    for (int d = 0; d < 6; ++d) {
      if (!inside[d]) continue;
      const auto m = static_cast<std::size_t>(static_cast<std::int64_t>(n) + steps[d]);
      if (bone.data[m]) {
        bright = std::max(bright, static_cast<double>(ct.data[m]));
      } else {
        outside_sum += ct.data[m];
        ++outside;
      }
    }
    if (outside == 0 || bright < -1e8) return;
    if (ct.data[n] < (bright + outside_sum / outside) / 2.0) trim.data[n] = 1;
  });
  for_each_nonzero(trim, [&](std::size_t n) { bone.data[n] = 0; });
}

void remove_small_islands(double min_island_ml, Mask& bone) {
  const Grid& g = bone.grid;
  const RunTable runs = extract_runs(bone, false);
  const RunLabels labels = label_runs(g, runs);
  const double ml = voxel_ml(g);
  rewrite_runs(
      g, runs, labels,
      [&](std::int64_t c) { return static_cast<double>(labels.voxels[c]) * ml >= min_island_ml; },
      bone);
}

}  // namespace

PatientAxes patient_axes(const Grid& grid) {
  const auto& d = grid.world.direction;  // row-major; column a is index axis a
  const auto component = [&](int row, int axis) {
    return d[static_cast<std::size_t>(row * 3 + axis)];
  };
  PatientAxes axes;
  int slice = 0;
  for (int a = 1; a < 3; ++a)
    if (std::abs(component(2, a)) > std::abs(component(2, slice))) slice = a;
  if (std::abs(component(2, slice)) < 0.5) return axes;  // no usable direction: i, j, k
  int posterior = slice == 0 ? 1 : 0;
  for (int a = 0; a < 3; ++a)
    if (a != slice && std::abs(component(1, a)) > std::abs(component(1, posterior))) posterior = a;
  axes.slice = slice;
  axes.posterior = posterior;
  axes.lateral = 3 - slice - posterior;
  axes.posterior_increasing = component(1, posterior) > 0.0;
  return axes;
}

Mask segment_body(const CtVolume& ct, const SegmentationParams& params, SegmentationStats* stats) {
  check_params(params);
  const PatientAxes axes = patient_axes(ct.grid);
  Mask body = threshold_above(ct, params.body_threshold_hu);  // not air
  const std::uint64_t above = count_nonzero(body);
  const std::uint64_t table = remove_table(axes, params, body);  // table, pad, cables
  mark_cores(axes, params.body_core_radius_mm, body);            // voxels deep inside
  keep_patient_parts(params.min_body_part_ml, body);             // large parts with a core
  const std::uint64_t kept_above = count_nonzero(body);
  fill_axial_holes(axes, body);  // internal air, per slice
  if (stats) {
    stats->body_voxels = count_nonzero(body);
    stats->removed_non_patient_voxels = above - kept_above;
    stats->table_voxels = table;
  }
  return body;
}

Mask segment_bone(const CtVolume& ct, const Mask& body, const SegmentationParams& params,
                  SegmentationStats* stats) {
  check_params(params);
  if (body.grid.dims != ct.grid.dims || body.size() != ct.size())
    throw UsageError("segment_bone: the body mask is not on the CT's grid");
  const PatientAxes axes = patient_axes(ct.grid);
  Mask bone = bone_candidates(ct, body, params);          // seeds and growable voxels
  keep_seeded_regions(bone);                              // region growing from the seeds
  remove_leaks(params.bone_leak_contact_fraction, bone);  // vessels resting on bone
  for_each_nonzero(bone, [&](std::size_t n) { bone.data[n] = 1; });
  fill_marrow(ct, axes, params, bone);                      // marrow, slice by slice
  fill_enclosed_cavities(params.bone_max_cavity_ml, bone);  // marrow enclosed in 3D
  refine_surface(ct, bone);                                 // half-maximum surface
  remove_small_islands(params.min_bone_island_ml, bone);    // islands
  if (stats) stats->bone_voxels = count_nonzero(bone);
  return bone;
}

}  // namespace palp
