// The bone mask (segment_bone): seeded region growing, leak removal, marrow, surface, islands.
//
// Values while growing: 2 = seed, 1 = grown voxel below the seed level.
#include "prep/segmentation.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "prep/components.hpp"
#include "prep/segmentation_shared.hpp"
#include "prep/slice_planes.hpp"

namespace palp {
namespace segmentation {
namespace {

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
// the half-maximum edge, where partial volume puts the true surface. Only where the bone is thick
// enough to hold an interior voxel (one with no face neighbour outside) next to it: in a rib or
// cortex one or two voxels across every voxel is partial volume, no neighbour gives the bone's
// full HU, and the rule would erode the structure instead of placing its edge.
void refine_surface(const CtVolume& ct, Mask& bone) {
  const Grid& g = bone.grid;
  Mask trim(g, 0, "bone surface");
  Mask surface(g, 0, "bone surface voxels");
  for_each_nonzero(bone, [&](std::size_t n) {
    if (any_face_neighbour(g, n, [&](std::int64_t m) { return !bone.data[m]; }))
      surface.data[n] = 1;
  });
  const auto interior = [&](std::int64_t m) { return bone.data[m] && !surface.data[m]; };
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const std::int64_t steps[6] = {-1, 1, -nx, nx, -nx * ny, nx * ny};
  for_each_nonzero(bone, [&](std::size_t n) {
    if (!any_face_neighbour(g, n, interior)) return;  // thin: no voxel of full HU beside it
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
}  // namespace segmentation

Mask segment_bone(const CtVolume& ct, const Mask& body, const SegmentationParams& params,
                  SegmentationStats* stats) {
  using namespace segmentation;
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
