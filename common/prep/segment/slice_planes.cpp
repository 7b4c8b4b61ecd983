// Slices as 2D planes and the per-plane labelling steps (see slice_planes.hpp).
#include "prep/segment/slice_planes.hpp"

#include <algorithm>

namespace palp::segmentation {
namespace {

std::int64_t axis_stride(const Grid& g, int axis) {
  return axis == 0 ? 1 : axis == 1 ? g.dims[0] : g.dims[0] * g.dims[1];
}

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

}  // namespace

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

Plane sagittal_plane(const Grid& g, const PatientAxes& axes, std::int64_t s) {
  Plane p;
  p.nu = g.dims[axes.posterior];
  p.nv = g.dims[axes.slice];
  p.su = axis_stride(g, axes.posterior);
  p.sv = axis_stride(g, axes.slice);
  p.u_mm = g.spacing[axes.posterior];
  p.v_mm = g.spacing[axes.slice];
  p.base = s * axis_stride(g, axes.lateral);
  return p;
}

void label_plane_background(const Plane& p, const std::uint8_t* mask, PlaneScratch& s) {
  label_plane(p, mask, true, s);
}

void label_plane(const Plane& p, const std::uint8_t* mask, bool zeros, PlaneScratch& s) {
  scan_plane(p, mask, zeros, s.runs);
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

}  // namespace palp::segmentation
