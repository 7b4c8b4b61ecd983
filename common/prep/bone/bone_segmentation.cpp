// The bone mask (segment_bone): seeded region growing, lumen and leak removal, marrow,
// surface, notches, islands, calculi.
//
// Values while growing: 2 = seed, 1 = grown voxel below the seed level.
#include "prep/segment/segmentation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "prep/bone/bone_enclosure.hpp"
#include "prep/bone/bone_islands.hpp"
#include "prep/bone/bone_lumens.hpp"
#include "prep/bone/bone_marrow.hpp"
#include "prep/bone/bone_ribs.hpp"
#include "prep/segment/components.hpp"
#include "prep/segment/notches.hpp"
#include "prep/segment/segmentation_shared.hpp"

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

// Skin clearance: candidates within `clearance_mm` of a voxel outside the body, along any axis (at
// least one voxel), are cleared. Neighbours beyond the scan's border are not outside: the body
// goes on there.
void clear_skin(const Mask& body, double clearance_mm, Mask& bone) {
  if (clearance_mm <= 0.0) return;
  const Grid& g = bone.grid;
  std::int64_t reach[3];
  for (int a = 0; a < 3; ++a)
    reach[a] = std::max<std::int64_t>(
        1, static_cast<std::int64_t>(std::floor(clearance_mm / g.spacing[a] + 1e-9)));
  const std::int64_t stride[3] = {1, g.dims[0], g.dims[0] * g.dims[1]};
  parallel_for_chunks(g.dims[2], 2, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t k = k0; k < k1; ++k)
      for (std::int64_t j = 0; j < g.dims[1]; ++j) {
        const std::uint8_t* row = bone.data.data() + g.linear(0, j, k);
        // The candidates of the row, found eight bytes at a time (next_byte).
        for (std::int64_t i = next_byte(row, 0, g.dims[0], true); i < g.dims[0];
             i = next_byte(row, i + 1, g.dims[0], true)) {
          const std::size_t n = g.linear(i, j, k);
          const std::int64_t at[3] = {i, j, k};
          bool near_outside = false;
          for (int a = 0; a < 3 && !near_outside; ++a) {
            const std::int64_t lo = std::max<std::int64_t>(0, at[a] - reach[a]);
            const std::int64_t hi = std::min<std::int64_t>(g.dims[a] - 1, at[a] + reach[a]);
            const auto base = static_cast<std::int64_t>(n) - at[a] * stride[a];
            for (std::int64_t q = lo; q <= hi && !near_outside; ++q)
              near_outside = !body.data[static_cast<std::size_t>(base + q * stride[a])];
          }
          // Each voxel reads only the body mask: clearing one changes nothing another sees (nor
          // the row's scan, which has passed it).
          if (near_outside) bone.data[n] = 0;
        }
      }
  });
}

// Region growing: the candidate regions (6-connected) that hold a seed, values kept, and those
// that `also(runs, labels, seeded)` marks (per component), made seeds throughout.
template <class Also>
void keep_seeded_regions(Mask& bone, Also also) {
  const Grid& g = bone.grid;
  const RunTable runs = extract_runs(bone, false);
  const RunLabels labels = label_runs(g, runs);
  const auto seeded =
      components_with(g, runs, labels, [&](std::size_t n) { return bone.data[n] == 2; });
  const std::vector<std::uint8_t> kept = also(runs, labels, seeded);
  for_each_run(g, runs, [&](std::int64_t r, std::int64_t, std::size_t first) {
    const std::int64_t c = labels.of_run[r];
    if (seeded[c]) return;
    std::fill_n(bone.data.begin() + static_cast<std::ptrdiff_t>(first),
                runs.runs[r].end - runs.runs[r].begin, static_cast<std::uint8_t>(kept[c] ? 2 : 0));
  });
}

void keep_seeded_regions(Mask& bone) {
  keep_seeded_regions(
      bone, [](const RunTable&, const RunLabels&, const std::vector<std::uint8_t>& seeded) {
        return std::vector<std::uint8_t>(seeded.size(), 0);
      });
}

// Leak removal: the grown voxels below the seed level that are not next to a seed form pieces;
// a piece that touches the seeds' rim with fewer than `fraction` of its voxels hangs on the bone by
// a narrow contact — a contrast-filled vessel or an enhancing organ — and is dropped, and with it
// the contact itself: the grown voxels of the rim that touch a dropped piece are the vessel's wall
// against the bone (its HU, not bone's), which the edge trim would otherwise have to remove.
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
  const std::vector<std::int64_t> contact = count_per_component(
      g, runs, labels, [&](std::size_t n) { return any_face_neighbour(g, n, is_rim); });
  for_each_run(g, runs, [&](std::int64_t r, std::int64_t, std::size_t first) {
    const std::int64_t c = labels.of_run[r];
    if (static_cast<double>(contact[c]) >= fraction * static_cast<double>(labels.voxels[c])) return;
    std::fill_n(bone.data.begin() + static_cast<std::ptrdiff_t>(first),
                runs.runs[r].end - runs.runs[r].begin, std::uint8_t{0});
  });
  const auto dropped = [&](std::int64_t m) { return piece.data[m] && !bone.data[m]; };
  const std::vector<std::size_t> wall = nonzero_where(bone, [&](std::size_t n) {
    return bone.data[n] == 1 && !piece.data[n] && any_face_neighbour(g, n, dropped);
  });
  for (const std::size_t n : wall) bone.data[n] = 0;
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
// HU reaches `fraction` of the way from the mean of its outside neighbours to its brightest bone
// neighbour — a partial-volume edge (0.5 would be the half-maximum; see SegmentationParams for
// why less). Nothing is trimmed with fraction 0. Only where the bone is thick
// enough to hold an interior voxel (one with no face neighbour outside) next to it: in a rib or
// cortex one or two voxels across every voxel is partial volume, no neighbour gives the bone's
// full HU, and the rule would erode the structure instead of placing its edge.
void refine_surface(const CtVolume& ct, double fraction, Mask& bone) {
  if (fraction <= 0.0) return;
  const Grid& g = bone.grid;
  Mask surface(g, 0, "bone surface voxels");
  for_each_nonzero(bone, [&](std::size_t n) {
    if (any_face_neighbour(g, n, [&](std::int64_t m) { return !bone.data[m]; }))
      surface.data[n] = 1;
  });
  const auto interior = [&](std::int64_t m) { return bone.data[m] && !surface.data[m]; };
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const std::int64_t steps[6] = {-1, 1, -nx, nx, -nx * ny, nx * ny};
  const std::vector<std::size_t> trim = nonzero_where(bone, [&](std::size_t n) {
    if (!any_face_neighbour(g, n, interior)) return false;  // thin: no voxel of full HU beside it
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
    if (outside == 0 || bright < -1e8) return false;
    const double out_hu = outside_sum / outside;
    return ct.data[n] < out_hu + fraction * (bright - out_hu);
  });
  for (const std::size_t n : trim) bone.data[n] = 0;
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

// Bone islands whose surface lies mostly on a lumen: a flap, a calcified wall, the partial volume
// of the lumen's edge or the heart's trabeculae, none of them a bone to feel. An island's surface
// faces (on a non-bone voxel inside the grid) are counted, and those on `lumen`; the island goes
// when at least half are. The skeleton, resting on a vessel along a strip, keeps its bone. Run
// before the marrow rules as well: a calcified flap a few millimetres from a vertebra is, seen
// from the vertebra, a second cortex, and the marrow rules would bracket the tissue between them
// and join the flap to the skeleton (a dissection's calcified intima beside the spine).
void remove_islands_on_lumens(const Mask& lumen, Mask& bone) {
  const Grid& g = bone.grid;
  const RunTable runs = extract_runs(bone, false);
  const RunLabels labels = label_runs(g, runs);
  std::vector<std::int64_t> faces(labels.voxels.size(), 0), on_lumen(labels.voxels.size(), 0);
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const std::int64_t steps[6] = {-1, 1, -nx, nx, -nx * ny, nx * ny};
  for (std::size_t r = 0; r < runs.runs.size(); ++r) {
    const auto row =
        static_cast<std::int64_t>(std::upper_bound(runs.row_start.begin(), runs.row_start.end(),
                                                   static_cast<std::int64_t>(r)) -
                                  runs.row_start.begin() - 1);
    const std::int64_t j = row % ny, k = row / ny;
    const auto c = static_cast<std::size_t>(labels.of_run[r]);
    for (std::int64_t i = runs.runs[r].begin; i < runs.runs[r].end; ++i) {
      const auto n = static_cast<std::int64_t>(g.linear(i, j, k));
      const bool inside[6] = {i > 0, i + 1 < nx, j > 0, j + 1 < ny, k > 0, k + 1 < nz};
      for (int d = 0; d < 6; ++d) {
        if (!inside[d] || bone.data[n + steps[d]]) continue;
        ++faces[c];
        on_lumen[c] += lumen.data[n + steps[d]] != 0;
      }
    }
  }
  rewrite_runs(
      g, runs, labels, [&](std::int64_t c) { return 2 * on_lumen[c] < faces[c] || faces[c] == 0; },
      bone);
}

// Where a lumen rests on bone whose cortex the scan blurs, the lumen's voxels beside the bone
// take the cortex's place and the marrow behind them is open, so the marrow rules left it out.
// With the lumen's voxels beside bone counted as its shell, the marrow rules run again; what they
// fill, less the lumen, is bone.
void close_marrow_behind_lumens(const PatientAxes& axes, const SegmentationParams& params,
                                const Mask& body, const Mask& lumen, Mask& bone) {
  const Grid& g = bone.grid;
  Mask shell = bone;
  for_each_nonzero(lumen, [&](std::size_t n) {
    if (any_face_neighbour(g, n, [&](std::int64_t m) { return bone.data[m] != 0; }))
      shell.data[n] = 1;
  });
  fill_marrow_by_votes(axes, params, shell);
  fill_between_cortices(axes, params, body, shell);
  fill_enclosed_cavities(params.bone_max_cavity_ml, shell);
  // What the second pass adds beside the lumen is the lumen's edge, not marrow.
  for_each_nonzero(shell, [&](std::size_t n) {
    if (!bone.data[n] && !lumen.data[n] &&
        any_face_neighbour(g, n, [&](std::int64_t m) { return lumen.data[m] != 0; }))
      shell.data[n] = 0;
  });
  bone = std::move(shell);
}

// Clears `bone` wherever `other` is set.
void clear_where(const Mask& other, Mask& bone) {
  for_each_nonzero(other, [&](std::size_t n) { bone.data[n] = 0; });
}

}  // namespace
}  // namespace segmentation

// Notches: a body voxel outside the bone with bone on at least `faces` (4 or more) of its six faces
// lies in a pit, a tunnel or a gap narrower than a voxel in the bone's surface. A bone's surface is
// smooth at the scale of a 1-3 mm voxel, so such a voxel is the bone's own partial volume (or a
// voxel the edge trim cut out of a concave surface, judged by its one or two outside neighbours),
// not tissue; a canal, foramen, disc or joint space the scan resolves (two voxels or more across)
// never has four bone faces. Filled by prep/segment/notches.hpp.
Mask segment_bone(const CtVolume& ct, const Mask& body, const SegmentationParams& params,
                  SegmentationStats* stats, const Mask* not_bone) {
  using namespace segmentation;
  check_params(params);
  if (body.grid.dims != ct.grid.dims || body.size() != ct.size())
    throw UsageError("segment_bone: the body mask is not on the CT's grid");
  if (not_bone && (not_bone->grid.dims != ct.grid.dims || not_bone->size() != ct.size()))
    throw UsageError("segment_bone: the not-bone mask is not on the CT's grid");
  const PatientAxes axes = patient_axes(ct.grid);
  Mask bone = bone_candidates(ct, body, params);          // seeds and growable voxels
  if (not_bone) clear_where(*not_bone, bone);             // lumens: neither seed nor grow
  clear_skin(body, params.bone_skin_clearance_mm, bone);  // none on the skin (kernel overshoot)
  // Region growing from the seeds; ribs blurred under the seed level kept without one.
  keep_seeded_regions(bone, [&](const RunTable& runs, const RunLabels& labels,
                                const std::vector<std::uint8_t>& seeded) {
    return unseeded_ribs(ct, body, axes, runs, labels, seeded, params);
  });
  if (remove_lumens(ct, params, bone) > 0) keep_seeded_regions(bone);  // seed-bright lumens
  remove_leaks(params.bone_leak_contact_fraction, bone);               // vessels resting on bone
  for_each_nonzero(bone, [&](std::size_t n) { bone.data[n] = 1; });
  remove_lumen_islands(ct, params, bone);                   // filled lumens apart from bone
  if (not_bone) remove_islands_on_lumens(*not_bone, bone);  // flaps before marrow joins them
  fill_marrow_by_votes(axes, params, bone);                 // marrow: enclosed in 2 of 3 planes
  fill_between_cortices(axes, params, body, bone);          // marrow: bracketed along most lines
  fill_enclosed_cavities(params.bone_max_cavity_ml, bone);  // marrow enclosed in 3D
  refine_surface(ct, params.bone_edge_fraction, bone);      // partial-volume edge
  fill_notches(body, params.bone_notch_faces, bone);        // notches narrower than a voxel
  remove_small_islands(params.min_bone_island_ml, bone);    // islands
  remove_compact_islands(params, bone);                     // calculi, calcified nodes
  if (not_bone) {
    if (params.bone_marrow_behind_lumens)  // a lumen on a cortex the scan blurs
      close_marrow_behind_lumens(axes, params, body, *not_bone, bone);
    clear_where(*not_bone, bone);               // marrow rules never fill a lumen back
    remove_islands_on_lumens(*not_bone, bone);  // flaps, walls, trabeculae of a lumen
    remove_small_islands(params.min_bone_island_ml, bone);
  }
  if (stats) stats->bone_voxels = count_nonzero(bone);
  return bone;
}

}  // namespace palp
