// Slices of a volume as 2D planes, and the per-plane labelling steps (holes, outside air, cores).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "base/volume.hpp"
#include "prep/segment/components.hpp"
#include "prep/segment/segmentation.hpp"

namespace palp::segmentation {

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
Plane axial_plane(const Grid& g, const PatientAxes& axes, std::int64_t s);

// Coronal slice `s` (across the posterior axis): u runs across the patient, v along the slices.
Plane coronal_plane(const Grid& g, const PatientAxes& axes, std::int64_t s);

// Sagittal slice `s` (across the lateral axis): u runs along the posterior axis, v along the
// slices.
Plane sagittal_plane(const Grid& g, const PatientAxes& axes, std::int64_t s);

// Runs of one plane along u, row by row in v.
struct PlaneRuns {
  std::vector<Run> runs;
  std::vector<std::int64_t> row_start;
};

// Reusable buffers for the per-slice steps of one thread.
struct PlaneScratch {
  PlaneRuns runs;
  DisjointSets sets;
  std::vector<std::uint8_t> flags;
  std::vector<std::int64_t> area;
  std::vector<std::uint8_t> cells, tmp, closed, marrow;
  std::vector<std::int64_t> counts;
};

// Labels the nonzero voxels of `mask` in one plane (with `zeros`, the zero ones), 4-connected:
// s.runs holds their runs, s.sets unites them into regions, s.flags[root] = 1 for the regions
// that reach the plane's edge and s.area[root] gets each region's size (voxels).
void label_plane(const Plane& p, const std::uint8_t* mask, bool zeros, PlaneScratch& s);

// label_plane of the zeros: the background's regions.
void label_plane_background(const Plane& p, const std::uint8_t* mask, PlaneScratch& s);

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
void mark_outside_air(const Plane& p, const std::uint8_t* mask, PlaneScratch& s);

// Marks with 2 the voxels of `mask` whose box neighbourhood (half sizes ru, rv) is all nonzero.
void mark_plane_cores(const Plane& p, std::uint8_t* mask, std::int64_t ru, std::int64_t rv,
                      PlaneScratch& s);

}  // namespace palp::segmentation
