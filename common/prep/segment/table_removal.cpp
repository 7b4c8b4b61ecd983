// Table, pad and cable removal in the axial slices of the body mask (see table_removal.hpp).
//
// In each axial slice, walking each column from the back, the runs of "not air" met before the
// patient are candidates: thin (<= max thickness) and with outside air in front (a posterior chest
// wall has the enclosed lung in front of it; a run that fails either test is the patient).
// Candidates that join (8-connected) into a band wide enough are table. Where a pad touches the
// patient, the band is followed under the patient along its interpolated top and bottom, and on
// past it through the table's own thin runs at the band's level (the pad's end beyond an arm).
#include "prep/segment/table_removal.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <utility>
#include <vector>

#include "base/parallel.hpp"
#include "prep/segment/components.hpp"
#include "prep/segment/slice_planes.hpp"

namespace palp::segmentation {
namespace {

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
  std::vector<std::uint8_t> none;   // a row of zeros (before the first row and after the last)
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
    // A run from the scan's back edge is the patient cut by the field of view (a crop through the
    // trunk, a lung cut open at the side in front of it), not a table: the table lies inside the
    // field of view below the patient, with air, a pad or a board's thin shell behind it.
    const bool cut_by_edge = v0 == 0;
    if (v1 - v0 > lim.max_thickness || !outside_in_front || cut_by_edge) {
      s.blocked[u] = 1;
      s.thick[u] = {u, v0, v1};
    } else {
      s.candidates.push_back({u, v0, v1});
    }
  };
  const auto visit = [&](std::int64_t u, std::int64_t v) {
    const bool on = v < p.nv && mask[p.at(u, v)] != 0;
    if (on && s.open[u] < 0) s.open[u] = v;
    if (!on && s.open[u] >= 0) {
      close(u, s.open[u], v);
      s.open[u] = -1;
    }
  };
  if (p.su != 1) {
    for (std::int64_t v = 0; v <= p.nv; ++v)
      for (std::int64_t u = 0; u < p.nu; ++u) visit(u, v);
  } else {
    // Rows along memory: a column's run opens or closes only where its byte differs from the row
    // behind (open[u] >= 0 exactly when that byte is nonzero), so only the bytes that differ are
    // visited, found eight at a time; the others would change nothing. Same calls, same order.
    s.none.assign(static_cast<std::size_t>(p.nu), 0);
    for (std::int64_t v = 0; v <= p.nv; ++v) {
      const std::uint8_t* row = v < p.nv ? mask + p.at(0, v) : s.none.data();
      const std::uint8_t* behind = v > 0 ? mask + p.at(0, v - 1) : s.none.data();
      std::int64_t u = 0;
      for (; u + 8 <= p.nu; u += 8) {
        std::uint64_t a = 0, b = 0;
        std::memcpy(&a, row + u, 8);
        std::memcpy(&b, behind + u, 8);
        if (a == b) continue;
        for (std::int64_t i = u; i < u + 8; ++i)
          if (row[i] != behind[i]) visit(i, v);
      }
      for (; u < p.nu; ++u)
        if (row[u] != behind[u]) visit(u, v);
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

// A candidate of column u (one that is not a band by itself) that is the table at the band's
// level: from the band's bottom (within the tolerance) to no higher than its top (within it);
// -1 if none.
std::int64_t table_piece(const TableScratch& s, std::int64_t u, std::int64_t bottom,
                         std::int64_t top, std::int64_t tolerance) {
  for (std::int64_t r = s.column_start[u]; r < s.column_start[u + 1]; ++r) {
    const ColumnRun& run = s.candidates[r];
    if (std::abs(run.v0 - bottom) <= tolerance && run.v1 <= top + tolerance) return r;
  }
  return -1;
}

// Under the patient, a pad that touches the back merges with the body into one thick run. From
// each side of such a stretch of columns the band is followed inward while the column's thick run
// starts where the interpolated band bottom is; the rows up to the interpolated band top are
// cleared. Past an arm resting on the pad near its end, the pad's end and the board beyond it are
// too narrow to be a band of their own (the arm parts them from the table, the scan's side edge or
// the next contact ends them): a column whose thin run lies at the band's level, from its bottom to
// no higher than its top (each within 2 mm), is the band followed on, and is cleared too.
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
      const auto [bottom, top] = slab(u);
      if (done[u]) return false;
      ColumnRun run = s.thick[u];  // the patient on the band: cleared up to the band's top
      if (run.v0 < 0 || std::abs(run.v0 - bottom) > lim.tolerance || run.v1 < top ||
          top <= run.v0) {
        const std::int64_t piece = table_piece(s, u, bottom, top, lim.tolerance);
        if (piece < 0) return false;
        run = s.candidates[piece];  // the table's own thin run at the band's level
      } else {
        run.v1 = top;
      }
      if (run.v0 > previous.v1 || previous.v0 > run.v1) return false;
      for (std::int64_t v = run.v0; v < run.v1; ++v) mask[p.at(u, v)] = 0;
      cleared += static_cast<std::uint64_t>(run.v1 - run.v0);
      done[u] = 1;
      previous = run;
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

}  // namespace

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

}  // namespace palp::segmentation
