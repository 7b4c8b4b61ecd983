// Contrast-filled lumens resting on bone (bone_lumens.hpp).
#include "prep/bone/bone_lumens.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "prep/bone/bone_islands.hpp"
#include "prep/maps/distance_transform.hpp"
#include "prep/segment/components.hpp"
#include "prep/segment/segmentation_shared.hpp"

namespace palp::segmentation {
namespace {

// Whether a component's box is at least twice `radius` across along every axis (a voxel counted
// whole at each end): the least a core of that radius needs.
bool wide_enough_for_core(const ComponentBox& box, const Grid& g, double radius) {
  for (int axis = 0; axis < 3; ++axis)
    if (static_cast<double>(box.hi[axis] - box.lo[axis] + 2) * g.spacing[axis] < 2.0 * radius)
      return false;
  return true;
}

// The levels the lumen search reads a voxel against: the bone's seed level and the cortex's.
struct LumenLevels {
  const CtVolume& ct;
  const Mask& bone;
  int cortex = 0, seed = 0;
  // A bone voxel at the cortex level or above.
  bool bright(std::int64_t m) const { return bone.data[m] && ct.data[m] >= cortex; }
  // A voxel from the seed level up to below the cortex level.
  bool between(std::size_t n) const { return ct.data[n] >= seed && ct.data[n] < cortex; }
};

// The pieces: the bone's voxels of seed level below the cortex level, apart from the cortex by
// one voxel (the rim: the voxels of that range beside the cortex, i.e. the rest of that range;
// its own mask is made only once a candidate is found).
Mask lumen_pieces(const LumenLevels& lv) {
  const Grid& g = lv.bone.grid;
  Mask piece(g, 0, "bone lumen pieces");
  const auto bright = [&](std::int64_t m) { return lv.bright(m); };
  for_each_nonzero(lv.bone, [&](std::size_t n) {
    if (lv.between(n) && !any_face_neighbour(g, n, bright)) piece.data[n] = 1;
  });
  return piece;
}

// Per piece, whether it may be a lumen: resting on the rim along a minor share of its surface
// (marrow of seed level is enclosed by its cortex), wide enough along every axis to hold a core.
// A piece that touches no cortex at all is a region without any cortical voxel, which this
// cannot tell from bone (a solid bone whose cortex reads below the level): it stays.
std::vector<std::uint8_t> candidate_pieces(const LumenLevels& lv, const SegmentationParams& params,
                                           const Mask& piece, const RunTable& runs,
                                           const RunLabels& labels) {
  const Grid& g = piece.grid;
  // Per piece: its surface voxels, those of them beside the rim, and its extent.
  const auto on_rim = [&](std::int64_t m) {
    return lv.bone.data[m] && lv.between(static_cast<std::size_t>(m)) && !piece.data[m];
  };
  const auto off_piece = [&](std::int64_t m) { return !piece.data[m]; };
  const auto on_surface = [&](std::size_t n) { return any_face_neighbour(g, n, off_piece); };
  const std::vector<std::int64_t> surface = count_per_component(g, runs, labels, on_surface);
  const std::vector<std::int64_t> contact = count_per_component(
      g, runs, labels,
      [&](std::size_t n) { return on_surface(n) && any_face_neighbour(g, n, on_rim); });
  const std::vector<ComponentBox> boxes = component_boxes(g, runs, labels);
  std::vector<std::uint8_t> candidate(labels.voxels.size(), 0);
  for (std::size_t c = 0; c < candidate.size(); ++c)
    candidate[c] = wide_enough_for_core(boxes[c], g, params.bone_lumen_radius_mm) &&
                   contact[c] > 0 &&
                   static_cast<double>(contact[c]) <
                       params.bone_lumen_max_contact * static_cast<double>(surface[c]);
  return candidate;
}

// The lumens: the candidates' opening by a ball of the radius, i.e. the voxels within the
// radius of a core voxel (one at least the radius from every voxel outside the candidates),
// and one voxel more (the wedges where the tube meets the cortex, which the ball cannot enter).
// A thin part — a rib, a cortex, a shell of dim cortex joined to a lumen — holds no core and
// lies beyond that reach. Nothing when no candidate holds a core.
std::optional<Mask> open_lumens(const Mask& candidates, double radius) {
  const Grid& g = candidates.grid;
  const double h = std::min({g.spacing[0], g.spacing[1], g.spacing[2]});
  const double largest = std::max({g.spacing[0], g.spacing[1], g.spacing[2]});
  const DistanceParams band{radius + 2.0 * largest, 0};
  DistanceMap depth = signed_distance(candidates, band);
  Mask core(g, 0, "bone lumen cores");
  for_each_nonzero(candidates, [&](std::size_t n) {
    if (depth.data[n] + 0.5 * h >= radius) core.data[n] = 1;
  });
  if (count_nonzero(core) == 0) return std::nullopt;
  const DistanceParams wider{radius + 3.0 * largest, 0};
  // The depth is done with: its grid-size float map takes the reach (the same values as a fresh
  // map, signed_distance's contract; a second fresh map costs its page faults, ~0.1 s at 512).
  DistanceMap reach = std::move(depth);
  signed_distance(core, wider, reach);
  std::optional<Mask> lumen(std::in_place, g, 0, "bone lumens");
  for_each_nonzero(candidates, [&](std::size_t n) {
    if (0.5 * h - reach.data[n] <= radius + largest) lumen->data[n] = 1;
  });
  return lumen;
}

// The lumen's edge against the cortex: a rim voxel beside the lumen stays bone only when it is
// brighter than its lumen neighbours (their mean) and passes the edge trim's partial-volume
// level (bone_edge_fraction of the way up to its brightest cortex neighbour) with the lumen as
// its outside; the rest of the rim is the lumen's and goes with it. `rim` keeps what goes.
void trim_rim(const LumenLevels& lv, const SegmentationParams& params, const Mask& lumen,
              Mask& rim) {
  const Grid& g = rim.grid;
  const CtVolume& ct = lv.ct;
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const std::int64_t steps[6] = {-1, 1, -nx, nx, -nx * ny, nx * ny};
  for_each_nonzero(rim, [&](std::size_t n) {
    const auto m = static_cast<std::int64_t>(n);
    const std::int64_t i = m % nx, j = (m / nx) % ny, k = m / (nx * ny);
    const bool inside[6] = {i > 0, i + 1 < nx, j > 0, j + 1 < ny, k > 0, k + 1 < nz};
    double top = -1e9, lumen_sum = 0.0;
    int lumen_count = 0;
    for (int d = 0; d < 6; ++d) {
      if (!inside[d]) continue;
      const auto o = static_cast<std::size_t>(m + steps[d]);
      if (lumen.data[o]) {
        lumen_sum += ct.data[o];
        ++lumen_count;
      } else if (lv.bright(static_cast<std::int64_t>(o))) {
        top = std::max(top, static_cast<double>(ct.data[o]));
      }
    }
    if (lumen_count == 0) {
      rim.data[n] = 0;
      return;
    }
    const double out = lumen_sum / lumen_count;
    const bool edge =
        ct.data[n] <= out || ct.data[n] < out + params.bone_edge_fraction * (top - out);
    rim.data[n] = edge;
  });
}

// One island in its own box with one voxel of outside around it; `first` is the box's first
// voxel in the scan's grid.
Mask island_in_box(const Grid& g, const RunTable& runs, const RunLabels& labels, std::size_t c,
                   const ComponentBox& bounds, Index3& first) {
  const Index3& lo = bounds.lo;
  const Index3& hi = bounds.hi;
  Grid box;
  for (int axis = 0; axis < 3; ++axis) {
    first[axis] = lo[axis] - 1;
    box.dims[axis] = hi[axis] - lo[axis] + 3;
  }
  box.spacing = g.spacing;
  Mask island(box, 0, "bone lumen island");
  for (std::int64_t k = lo[2]; k <= hi[2]; ++k)
    for (std::int64_t j = lo[1]; j <= hi[1]; ++j) {
      const std::int64_t row = j + g.dims[1] * k;
      for (std::int64_t r = runs.row_start[row]; r < runs.row_start[row + 1]; ++r) {
        if (static_cast<std::size_t>(labels.of_run[r]) != c) continue;
        for (std::int64_t i = runs.runs[r].begin; i < runs.runs[r].end; ++i)
          island.data[box.linear(i - first[0], j - first[1], k - first[2])] = 1;
      }
    }
  return island;
}

// Whether island c is a lumen: it holds a core of the radius, and that core's mean HU is below
// the cortex level and not below the mean of the island's surface.
bool island_is_lumen(const CtVolume& ct, const Grid& g, const RunTable& runs,
                     const RunLabels& labels, std::size_t c, const ComponentBox& bounds,
                     double radius, double cortex) {
  const double h = std::min({g.spacing[0], g.spacing[1], g.spacing[2]});
  const double largest = std::max({g.spacing[0], g.spacing[1], g.spacing[2]});
  Index3 first;
  const Mask island = island_in_box(g, runs, labels, c, bounds, first);
  const Grid& box = island.grid;
  const Index3& dims = box.dims;
  const DistanceMap depth = signed_distance(island, DistanceParams{radius + 2.0 * largest, 1});
  double core_sum = 0.0, surface_sum = 0.0;
  std::int64_t core_count = 0, surface_count = 0;
  // Outside the island and inside the scan: the scan's own border is no surface (a bone it
  // cuts shows its interior there).
  const auto outside = [&](std::int64_t m) {
    if (island.data[m] != 0) return false;
    const std::int64_t i = m % dims[0], j = (m / dims[0]) % dims[1], k = m / (dims[0] * dims[1]);
    const Index3 at{first[0] + i, first[1] + j, first[2] + k};
    for (int axis = 0; axis < 3; ++axis)
      if (at[axis] < 0 || at[axis] >= g.dims[axis]) return false;
    return true;
  };
  // The core first: an island without one (a rib) needs no surface (the sums, each in the
  // same voxel order as ever, are the same).
  const auto each_voxel = [&](auto visit) {
    for (std::int64_t k = 1; k + 1 < dims[2]; ++k)
      for (std::int64_t j = 1; j + 1 < dims[1]; ++j)
        for (std::int64_t i = 1; i + 1 < dims[0]; ++i) {
          const std::size_t m = box.linear(i, j, k);
          if (island.data[m])
            visit(m,
                  static_cast<double>(ct.data[g.linear(first[0] + i, first[1] + j, first[2] + k)]));
        }
  };
  each_voxel([&](std::size_t m, double hu) {
    if (depth.data[m] + 0.5 * h < radius) return;
    core_sum += hu;
    ++core_count;
  });
  if (core_count == 0) return false;
  each_voxel([&](std::size_t m, double hu) {
    if (!any_face_neighbour(box, m, outside)) return;
    surface_sum += hu;
    ++surface_count;
  });
  if (surface_count == 0) return false;
  const double core_hu = core_sum / static_cast<double>(core_count);
  return core_hu < cortex && core_hu >= surface_sum / static_cast<double>(surface_count);
}

// A bone the scan shows apart from the skeleton across a joint space (a femoral head, a
// vertebra across its facet joints) lies within the joint gap of it (bone_islands.hpp): a
// candidate that near the skeleton stays. (Not near any other island: loops of bowel lie beside
// each other and beside pieces of themselves too thin to hold a core.)
void keep_beside_skeleton(const Grid& g, const RunTable& runs, const RunLabels& labels,
                          std::size_t skeleton, const std::vector<ComponentBox>& boxes,
                          std::vector<std::uint8_t>& lumen) {
  Mask skeleton_only(g, 0, "bone lumen islands' skeleton");
  rewrite_runs(
      g, runs, labels, [&](std::int64_t c) { return static_cast<std::size_t>(c) == skeleton; },
      skeleton_only);
  const double reach = kBoneJointGapMm + g.max_spacing();
  for (std::size_t c = 0; c < lumen.size(); ++c)
    if (lumen[c] && near_other_bone(skeleton_only, runs, labels, static_cast<std::int64_t>(c),
                                    boxes[c].lo, boxes[c].hi, reach))
      lumen[c] = 0;
}

}  // namespace

std::uint64_t remove_lumens(const CtVolume& ct, const SegmentationParams& params, Mask& bone) {
  if (params.bone_lumen_radius_mm <= 0.0) return 0;
  const Grid& g = bone.grid;
  const LumenLevels lv{
      ct, bone, integer_floor(std::ceil(params.bone_seed_hu + params.bone_lumen_cortex_margin_hu)),
      integer_floor(std::ceil(params.bone_seed_hu))};
  const Mask piece = lumen_pieces(lv);
  const RunTable runs = extract_runs(piece, false);
  if (runs.runs.empty()) return 0;
  const RunLabels labels = label_runs(g, runs);
  const std::vector<std::uint8_t> candidate = candidate_pieces(lv, params, piece, runs, labels);
  if (std::none_of(candidate.begin(), candidate.end(), [](std::uint8_t c) { return c != 0; }))
    return 0;
  Mask rim(g, 0, "bone lumen rim");
  for_each_nonzero(bone, [&](std::size_t n) {
    if (lv.between(n) && !piece.data[n]) rim.data[n] = 1;
  });
  Mask candidates(g, 0, "bone lumen candidates");
  rewrite_runs(
      g, runs, labels, [&](std::int64_t c) { return candidate[c]; }, candidates);
  const std::optional<Mask> lumen = open_lumens(candidates, params.bone_lumen_radius_mm);
  if (!lumen) return 0;
  trim_rim(lv, params, *lumen, rim);
  const std::uint64_t removed = count_nonzero(*lumen) + count_nonzero(rim);
  for_each_nonzero(*lumen, [&](std::size_t n) { bone.data[n] = 0; });
  for_each_nonzero(rim, [&](std::size_t n) { bone.data[n] = 0; });
  return removed;
}

std::uint64_t remove_lumen_islands(const CtVolume& ct, const SegmentationParams& params,
                                   Mask& bone) {
  const double radius = params.bone_lumen_radius_mm;
  if (radius <= 0.0) return 0;
  const Grid& g = bone.grid;
  const double cortex = params.bone_seed_hu + params.bone_lumen_cortex_margin_hu;
  const RunTable runs = extract_runs(bone, false);
  if (runs.runs.empty()) return 0;
  const RunLabels labels = label_runs(g, runs);
  const std::size_t islands = labels.voxels.size();
  if (islands < 2) return 0;
  const auto skeleton = static_cast<std::size_t>(
      std::max_element(labels.voxels.begin(), labels.voxels.end()) - labels.voxels.begin());
  const std::vector<ComponentBox> boxes = component_boxes(g, runs, labels);
  std::vector<std::uint8_t> lumen(islands, 0);
  bool any = false;
  for (std::size_t c = 0; c < islands; ++c) {
    if (c == skeleton || !wide_enough_for_core(boxes[c], g, radius)) continue;
    lumen[c] = island_is_lumen(ct, g, runs, labels, c, boxes[c], radius, cortex);
    any = any || lumen[c];
  }
  if (!any) return 0;
  keep_beside_skeleton(g, runs, labels, skeleton, boxes, lumen);
  std::uint64_t removed = 0;
  for (std::size_t c = 0; c < islands; ++c)
    if (lumen[c]) removed += static_cast<std::uint64_t>(labels.voxels[c]);
  // The bone is 0/1 here: every run keeps 1 but a lumen's.
  rewrite_runs(
      g, runs, labels, [&](std::int64_t c) { return !lumen[static_cast<std::size_t>(c)]; }, bone);
  return removed;
}

}  // namespace palp::segmentation
