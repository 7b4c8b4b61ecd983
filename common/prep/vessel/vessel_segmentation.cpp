// Contrast-filled vessels (see vessel_segmentation.hpp). Data flow:
//   box         CT, body -> the search's box (vessel_search_box): the stages below run on the
//               scan cropped to it when that saves a tenth or more, the lumens pasted back
//   smooth      CT -> 3x3x3 mean HU (int16, one volume; vessel_filters.hpp)
//   cortex      CT -> bright ridges (cortex, trabeculae; vessel_filters.hpp); near = cortex and
//               its face neighbours
//   candidates  CT, smoothed HU, body, near -> contrast-level voxels away from cortex
//   open        candidates -> cores (split_mm deep) -> the voxels within split_mm of a core (on
//               the candidates' box)
//   parts       opened -> 6-connected parts; per part: voxels, HU moments, trunk, boundary faces,
//               faces on near, surface and inner HU
//   keep        parts -> lumens (size, trunk, contrast, shell, uniformity, surface, marrow)
//   organs      lumens -> less those that are no tube below half the brightest one's height or,
//               where a lumen is a tube, dimmer than it
//   rejoin      lumens -> grown through candidates the opening cut, away from rejected parts
//               and from cortex (branches)
//   phase       the lumens' trunk cores -> tubes and their levels -> two side by side at the
//               aorta's contrast or not -> contrast_phase (vessel_phase.hpp)
//   branches    lumens, CT, smoothed HU, cortex -> grown through voxels at the lumens' own
//               contrast, below cortical HU, clear of cortical voxels, not a shell's ridge, and
//               not walled in by cortex (marrow); then from the band on the scan's end slices,
//               kept where that growth is a tube as big as a lumen (vessel_branches.hpp)
//   close       lumens -> closed by closing_mm, then one voxel of the wall's partial volume
//   marrow      lumens, cortex -> less the voxels walled in by cortex on all six axis rays
//   outline     lumens, CT, cortex -> plus the tissue inside their round outlines (false lumens)
#include "prep/vessel/vessel_segmentation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "prep/bone/bone_islands.hpp"
#include "prep/maps/distance_transform.hpp"
#include "prep/segment/components.hpp"
#include "prep/segment/morphology.hpp"
#include "prep/segment/notches.hpp"
#include "prep/segment/segmentation.hpp"
#include "prep/vessel/vessel_box.hpp"
#include "prep/vessel/vessel_branches.hpp"
#include "prep/vessel/vessel_filters.hpp"
#include "prep/vessel/vessel_outline.hpp"
#include "prep/vessel/vessel_phase.hpp"

namespace palp {
namespace {

using segmentation::any_face_neighbour;
using segmentation::dilate_into;
using segmentation::dilate_once;
using segmentation::erode_into;
using segmentation::extract_runs;
using segmentation::grow_within;
using segmentation::label_runs;
using segmentation::remove;
using segmentation::RunLabels;
using segmentation::RunTable;
using segmentation::unite;

// Faces on the lumen (of six) that make a voxel the lumen's notch.
constexpr int kLumenNotchFaces = 4;

// A lumen found by its own tests loses only the voxels walled in on all six: marrow the scan's
// blurred cortex let through (a vertebra's, between its endplates).
constexpr int kWalledInSides = 6;

// cores' value for a voxel trunk_core_mm deep in the candidates (1: split_mm deep).
constexpr std::uint8_t kTrunkCore = 2;

// Whether voxel n of `mask`'s grid is in it or beside one of its voxels by a face: the mask
// dilated once, asked only where a growth reaches.
bool within_a_face(const Mask& mask, std::size_t n) {
  return mask.data[n] || segmentation::any_face_neighbour(
                             mask.grid, n, [&](std::int64_t m) { return mask.data[m] != 0; });
}

// mask &= (cores == kTrunkCore), through raw pointers (segmentation/morphology.hpp says why)
void keep_trunk_cores(const Mask& cores, Mask& mask) {
  const std::uint8_t* core = cores.data.data();
  std::uint8_t* m = mask.data.data();
  const std::size_t count = mask.size();
  for (std::size_t n = 0; n < count; ++n) m[n] = (m[n] != 0) & (core[n] == kTrunkCore);
}

struct PartStats {
  std::int64_t voxels = 0;
  double sum = 0.0, sum_sq = 0.0;
  std::int64_t faces = 0, cortex_faces = 0;
  // The stored HU of its surface voxels (a face on a non-candidate) and of the others.
  double surface_sum = 0.0, inner_sum = 0.0;
  std::int64_t surface_voxels = 0, inner_voxels = 0;
  bool trunk = false;  // holds a voxel trunk_core_mm deep in the candidates
  double mean() const { return sum / static_cast<double>(voxels); }
  double spread() const {
    const double m = mean();
    return std::sqrt(std::max(0.0, sum_sq / static_cast<double>(voxels) - m * m));
  }
};

// Per part: its size, HU moments and boundary faces (those beside a non-candidate), and of them
// the faces beside `near` (the cortex and the voxels beside it).
std::vector<PartStats> part_stats(const CtVolume& ct, const RunTable& runs, const RunLabels& labels,
                                  const Mask& candidates, const Mask& near,
                                  const std::vector<std::int16_t>& hu, const Mask& depth_class) {
  const Grid& g = ct.grid;
  std::vector<PartStats> stats(labels.voxels.size());
  const std::int64_t nx = g.dims[0];
  const std::int64_t step[3] = {1, nx, nx * g.dims[1]};
  for (std::int64_t row = 0; row + 1 < static_cast<std::int64_t>(runs.row_start.size()); ++row) {
    const std::int64_t j = row % g.dims[1], k = row / g.dims[1];
    for (std::int64_t r = runs.row_start[row]; r < runs.row_start[row + 1]; ++r) {
      PartStats& s = stats[static_cast<std::size_t>(labels.of_run[r])];
      for (std::int64_t i = runs.runs[r].begin; i < runs.runs[r].end; ++i) {
        const auto n = static_cast<std::int64_t>(g.linear(i, j, k));
        const double v = hu[n];
        ++s.voxels;
        s.trunk = s.trunk || depth_class.data[n] == kTrunkCore;
        s.sum += v;
        s.sum_sq += v * v;
        const std::int64_t at[3] = {i, j, k};
        const std::int64_t faces_before = s.faces;
        for (int a = 0; a < 3; ++a)
          for (int d = -1; d <= 1; d += 2) {
            const std::int64_t q = at[a] + d;
            if (q < 0 || q >= g.dims[a]) continue;  // the scan's border is not a wall
            const std::int64_t m = n + d * step[a];
            if (candidates.data[m]) continue;
            ++s.faces;
            s.cortex_faces += near.data[m] != 0;
          }
        const bool on_surface = s.faces > faces_before;
        (on_surface ? s.surface_sum : s.inner_sum) += ct.data[n];
        ++(on_surface ? s.surface_voxels : s.inner_voxels);
      }
    }
  }
  return stats;
}

// The part (of `labels` over `runs`) holding voxel (i, j, k), which must be one of them.
std::size_t part_at(const Grid& g, const RunTable& runs, const RunLabels& labels, std::int64_t i,
                    std::int64_t j, std::int64_t k) {
  const std::int64_t row = j + g.dims[1] * k;
  for (std::int64_t r = runs.row_start[row]; r < runs.row_start[row + 1]; ++r)
    if (runs.runs[r].begin <= i && i < runs.runs[r].end)
      return static_cast<std::size_t>(labels.of_run[r]);
  return labels.voxels.size();
}

// Drops (clears `keep` of) the kept parts whose mean smoothed HU is below `share` of the way from
// the soft tissue to `lumen_hu` (the brightest lumen's) and which hold no tube: neither the part
// nor any piece of its trunk core (`cores` == kTrunkCore) is tube-shaped (see the header:
// enhancing organs). The heart joined to the aorta holds the aorta's tube whatever lumen is
// brighter. Returns how many.
int drop_organs(const Grid& g, const RunTable& runs, const RunLabels& labels,
                const std::vector<PartStats>& stats, const Mask& cores, double soft_hu,
                double lumen_hu, const VesselParams& params, std::vector<std::uint8_t>& keep) {
  if (!(params.organ_below_share > 0.0)) return 0;
  const double below = soft_hu + params.organ_below_share * (lumen_hu - soft_hu);
  std::vector<std::uint8_t> tube(stats.size(), 0);
  const std::vector<segmentation::IslandShape> part_shapes =
      segmentation::island_shapes(g, runs, labels);
  for (std::size_t c = 0; c < stats.size(); ++c)
    tube[c] = part_shapes[c].sd[0] >= kTubeElongation * part_shapes[c].sd[1];
  Mask trunk(g, 0, "trunk cores of parts not tubes");
  segmentation::rewrite_runs(
      g, runs, labels, [&](std::int64_t c) { return keep[c] && !tube[c]; }, trunk);
  keep_trunk_cores(cores, trunk);
  const RunTable t = extract_runs(trunk, false);
  const RunLabels l = label_runs(g, t);
  const std::vector<segmentation::IslandShape> core_shapes = segmentation::island_shapes(g, t, l);
  const std::int64_t ny = g.dims[1];
  for (std::int64_t row = 0; row + 1 < static_cast<std::int64_t>(t.row_start.size()); ++row)
    for (std::int64_t r = t.row_start[row]; r < t.row_start[row + 1]; ++r) {
      const auto piece = static_cast<std::size_t>(l.of_run[r]);
      if (!is_tube(core_shapes[piece].sd, params.trunk_core_mm)) continue;
      const std::size_t c = part_at(g, runs, labels, t.runs[r].begin, row % ny, row / ny);
      if (c < tube.size()) tube[c] = 1;
    }
  // where the scan shows a lumen as a tube, a part dimmer than that tube holding none is an organ
  double tube_hu = -std::numeric_limits<double>::infinity();
  for (std::size_t c = 0; c < stats.size(); ++c)
    if (keep[c] && tube[c]) tube_hu = std::max(tube_hu, stats[c].mean());
  int dropped = 0;
  for (std::size_t c = 0; c < stats.size(); ++c) {
    if (!keep[c] || tube[c] || (stats[c].mean() >= below && stats[c].mean() >= tube_hu)) continue;
    keep[c] = 0;
    ++dropped;
  }
  return dropped;
}

enum class Verdict { lumen, small, thin, dim, shell, spread, surface };

// Whether a part is a lumen (see the header): size, trunk, cortex contact, uniformity, surface.
Verdict judge(const PartStats& s, double soft_peak_hu, double cortical_hu, double ml,
              const VesselParams& params) {
  if (static_cast<double>(s.voxels) * ml < params.min_lumen_ml) return Verdict::small;
  // Joined to a trunk: the aorta, a vena cava, the heart, whose core is as thick as no branch
  // apart from them, nor costal cartilage or a tendon of the same HU, is.
  if (!s.trunk) return Verdict::thin;
  // Contrast: the part's mean well above the soft tissue (enhancing organs, a haematoma, noise
  // above the candidates' level stay below it).
  if (s.mean() - soft_peak_hu < params.min_lumen_contrast_hu) return Verdict::dim;
  const double contact =
      s.faces > 0 ? static_cast<double>(s.cortex_faces) / static_cast<double>(s.faces) : 0.0;
  // Cancellous bone inside its cortex never averages this bright: a part that does is contrast,
  // whatever it rests on (a dissection's flap, the heart's trabeculae and the spine it touches
  // count as cortex contact).
  const bool clearly_contrast = s.mean() - soft_peak_hu >= params.clear_contrast_hu;
  if (contact > params.max_cortex_contact && !clearly_contrast) return Verdict::shell;
  // ... but a part beside cortex along most of its surface is walled in by it, unless it
  // averages cortical HU (no bone's marrow does; undiluted contrast, whose round edge reads as a
  // ridge along its tangents, may)
  if (contact > params.max_clear_contrast_contact && s.mean() < cortical_hu) return Verdict::shell;
  if (s.spread() > params.max_spread_fraction * (s.mean() - soft_peak_hu)) return Verdict::spread;
  // Bone is brightest at its surface (cortex over marrow); a lumen is uniform and its surface
  // darker (partial volume with its wall). Parts too thin for an inside are judged without.
  if (s.inner_voxels > 0 && s.surface_voxels > 0 &&
      s.surface_sum / static_cast<double>(s.surface_voxels) >
          s.inner_sum / static_cast<double>(s.inner_voxels))
    return Verdict::surface;
  return Verdict::lumen;
}

void count_verdict(Verdict v, VesselResult& r) {
  switch (v) {
    case Verdict::lumen:
      ++r.lumens;
      break;
    case Verdict::thin:
      ++r.rejected_thin;
      break;
    case Verdict::shell:
      ++r.rejected_shell;
      break;
    case Verdict::spread:
      ++r.rejected_spread;
      break;
    case Verdict::surface:
      ++r.rejected_surface;
      break;
    case Verdict::small:
    case Verdict::dim:
      break;
  }
}

// A lumen resting on bone whose cortex the scan blurs takes the bone's nearest marrow with it
// (the opening cannot part them along a broad contact). Its voxels below the half level from the
// soft tissue to the lumen's own level (the lumen's edge: partial volume) within two voxels of
// cortex are the bone's, not the lumen's.
void trim_by_cortex(const RunTable& runs, const RunLabels& labels,
                    const std::vector<PartStats>& stats, const std::vector<std::uint8_t>& keep,
                    const std::vector<std::int16_t>& hu, const Mask& near, double soft_hu,
                    Mask& lumen) {
  const Grid& g = lumen.grid;
  const std::int64_t ny = g.dims[1];
  for (std::int64_t row = 0; row + 1 < static_cast<std::int64_t>(runs.row_start.size()); ++row) {
    const std::int64_t j = row % ny, k = row / ny;
    for (std::int64_t r = runs.row_start[row]; r < runs.row_start[row + 1]; ++r) {
      const auto c = static_cast<std::size_t>(labels.of_run[r]);
      if (!keep[c]) continue;
      const double half = 0.5 * (soft_hu + stats[c].mean());
      for (std::int64_t i = runs.runs[r].begin; i < runs.runs[r].end; ++i) {
        const std::size_t n = g.linear(i, j, k);
        if (hu[n] < half && within_a_face(near, n)) lumen.data[n] = 0;
      }
    }
  }
}

void check(const CtVolume& ct, const Mask& body, double soft_peak_hu, const VesselParams& p) {
  if (body.grid.dims != ct.grid.dims || body.size() != ct.size())
    throw UsageError("segment_vessels: the body mask is not on the CT's grid");
  if (!(p.min_contrast_hu > 0.0) || !(p.ridge_drop > 0.0 && p.ridge_drop < 1.0) ||
      !(p.max_cortex_contact >= 0.0) || !(p.max_clear_contrast_contact >= 0.0) ||
      !(p.max_spread_fraction > 0.0) || !(p.min_lumen_ml >= 0.0) || !(p.closing_mm >= 0.0) ||
      !(p.trunk_core_mm >= 0.0 && p.trunk_core_mm <= 100.0) ||
      !(p.branch_clearance_mm >= 0.0 && p.branch_clearance_mm <= 20.0) ||
      !(p.organ_below_share >= 0.0 && p.organ_below_share < 1.0) ||
      !(p.branch_fence_ridge_directions >= 1 && p.branch_fence_ridge_directions <= 13) ||
      !(p.cortex_margin_hu > 0.0) ||
      !(p.marrow_enclosure_mm >= 0.0 && p.marrow_enclosure_mm <= 100.0) ||
      !(p.outline_max_radius_mm >= 0.0 && p.outline_max_radius_mm <= 100.0) ||
      !(p.outline_min_edge_share > 0.0 && p.outline_min_edge_share <= 1.0) ||
      !(p.outline_max_rms_mm > 0.0) || !(p.fat_peak_hu < soft_peak_hu))
    throw UsageError("segment_vessels: unusable parameters");
}

// Opens the candidates: those within split_mm of a voxel split_mm deep, so that a bridge of
// partial volume thinner than twice that (a lumen resting on a vertebra, a rib) parts them.
// `cores` receives 1 split_mm deep in the candidates, kTrunkCore trunk_core_mm deep (one float
// map, its buffer reused for the reach from the cores). On the grid it is given.
Mask open_on_grid(const Mask& candidates, const VesselParams& params, Mask& cores) {
  const Grid& g = candidates.grid;
  const double h_min = std::min({g.spacing[0], g.spacing[1], g.spacing[2]});
  const double h_max = std::max({g.spacing[0], g.spacing[1], g.spacing[2]});
  const double split = std::max(params.split_mm, h_min);
  DistanceMap depth = signed_distance(
      candidates, {std::max(split, params.trunk_core_mm) + 2.0 * h_max, 0, DistanceSide::inside});
  cores = Mask(g, 0, "vessel cores");
  const std::uint8_t* in = candidates.data.data();
  const float* deep = depth.data.data();
  std::uint8_t* core = cores.data.data();
  const double trunk_core = params.trunk_core_mm;
  const std::size_t count = cores.size();
  for (std::size_t n = 0; n < count; ++n) {
    const double d = deep[n] + 0.5 * h_min;
    core[n] = !in[n] ? 0 : d >= trunk_core ? kTrunkCore : d >= split ? 1 : 0;
  }
  signed_distance(cores, {split + 3.0 * h_max, 0, DistanceSide::outside}, depth);
  Mask opened(g, 0, "vessel parts");
  std::uint8_t* open = opened.data.data();
  const float* reach = depth.data.data();
  for (std::size_t n = 0; n < count; ++n)
    open[n] = (in[n] != 0) & (0.5 * h_min - reach[n] <= split + h_min);
  return opened;
}

// The same on the candidates' box grown by one voxel, pasted back: the distance maps, the
// opening's largest buffers, cover only that box. Exact: the nearest non-candidate of a
// candidate is never farther than the box's outer layer (all non-candidates), and every core lies
// in the box.
Mask open_candidates(const Mask& candidates, const VesselParams& params, Mask& cores) {
  const segmentation::VoxelBox box = segmentation::nonzero_box(candidates, 1);
  if (box.size(0) == 0) {  // no candidate: no distance map needed
    cores = Mask(candidates.grid, 0, "vessel cores");
    return Mask(candidates.grid, 0, "vessel parts");
  }
  if (!box_saves_a_tenth(box, candidates.size())) return open_on_grid(candidates, params, cores);
  Mask box_cores;
  const Mask box_opened = open_on_grid(crop(candidates, box), params, box_cores);
  Mask opened(candidates.grid, 0, "vessel parts");
  cores = Mask(candidates.grid, 0, "vessel cores");
  paste(box_opened, box, opened);
  paste(box_cores, box, cores);
  return opened;
}

// Closes the lumens over flap and plaque shadows (never into cortex), adds the wall's partial
// volume and fills their notches.
void close_lumens(const CtVolume& ct, const Mask& body, const Mask& cortex, const Mask& near,
                  const std::vector<std::int16_t>& hu, int low_hu, int max_pool_hu,
                  const VesselParams& params, Mask& lumen) {
  const Grid& g = ct.grid;
  const double h_min = std::min({g.spacing[0], g.spacing[1], g.spacing[2]});
  const auto below_cortex = [&](std::size_t n) {
    return body.data[n] && !cortex.data[n] && hu[n] < max_pool_hu;
  };
  const int steps = std::max(1, static_cast<int>(std::lround(params.closing_mm / h_min)));
  Mask closed = lumen, spare;  // two buffers, each step from one into the other
  // every step within the lumens' box grown by all the dilations' reach (nothing changes beyond)
  const segmentation::VoxelBox box = segmentation::nonzero_box(lumen, steps + 2);
  const auto off_cortex = [&](std::size_t n) { return below_cortex(n) && !near.data[n]; };
  for (int s = 0; s < steps; ++s) {
    dilate_into(closed, off_cortex, spare, box);
    std::swap(closed, spare);
  }
  for (int s = 0; s < steps; ++s) {
    erode_into(closed, spare, box);
    std::swap(closed, spare);
  }
  unite(lumen, closed);
  // the wall's partial volume: one voxel of contrast level beside the lumen, not by cortex (a
  // lumen's edge blurred into its wall, which bone's growing level would otherwise take)
  dilate_into(
      closed,
      [&](std::size_t n) { return below_cortex(n) && !near.data[n] && ct.data[n] >= low_hu; },
      lumen, box);
  // a voxel with the lumen on four or more of its six faces is the lumen's: a flap's bright
  // sliver or a corner of its edge, read as a ridge (cortex beside a lumen has its bone behind
  // it: at most three faces on the lumen)
  Mask& notch_room = spare;  // its memory reused
  const std::uint8_t* in_body = body.data.data();
  const std::int16_t* smooth = hu.data();
  std::uint8_t* room = notch_room.data.data();
  const std::size_t count = notch_room.size();
  for (std::size_t n = 0; n < count; ++n) room[n] = (in_body[n] != 0) & (smooth[n] < max_pool_hu);
  segmentation::fill_notches(notch_room, kLumenNotchFaces, lumen);
}

// A part judged a lumen that has more than half its voxels walled in by cortex on all six axis
// rays (through its own voxels; within marrow_enclosure_mm) is a vertebral body's marrow, not a
// lumen: a vessel runs on along its length. (Its verdict becomes `shell`: enclosed by cortex.)
void mark_marrow_parts(const CtVolume& ct, const RunTable& runs, const RunLabels& labels,
                       const Mask& cortex, double cortical_hu, double through_hu,
                       const VesselParams& params, std::vector<Verdict>& verdicts) {
  const Grid& g = ct.grid;
  Mask judged(g, 0, "parts judged lumens");
  segmentation::rewrite_runs(
      g, runs, labels, [&](std::int64_t c) { return verdicts[c] == Verdict::lumen; }, judged);
  const Mask walled = enclosed_by_cortex(ct, judged, cortex, cortical_hu, through_hu,
                                         params.marrow_enclosure_mm, kWalledInSides);
  const std::vector<std::int64_t> walled_voxels = segmentation::count_per_component(
      g, runs, labels, [&](std::size_t n) { return walled.data[n] != 0; });
  for (std::size_t c = 0; c < verdicts.size(); ++c)
    if (verdicts[c] == Verdict::lumen && 2 * walled_voxels[c] > labels.voxels[c])
      verdicts[c] = Verdict::shell;
}

// The search on the grid it is given (segment_vessels crops the scan to its box first).
VesselResult search_vessels(const CtVolume& ct, const Mask& body, double soft_peak_hu,
                            double bone_seed_hu, const VesselParams& params) {
  const Grid& g = ct.grid;
  VesselResult result;
  result.lumen = Mask(g, 0, "vessel mask");
  const std::vector<std::int16_t> hu = smoothed_hu(ct);  // 3x3x3 mean
  const int low_hu = static_cast<int>(std::lround(soft_peak_hu + params.min_contrast_hu));
  // candidates: contrast-level smoothed HU inside the body, not beside cortex
  const int max_pool_hu = static_cast<int>(std::lround(bone_seed_hu + params.max_pool_margin_hu));
  const Mask cortex = ridge_cortex(ct, bone_seed_hu, soft_peak_hu, params.ridge_drop);
  const Mask near = dilate_once(cortex);  // and beside it
  Mask candidates(g, 0, "vessel candidates");
  {  // raw pointers and no branches: the loop vectorizes
    const std::uint8_t* in_body = body.data.data();
    const std::uint8_t* by_cortex = near.data.data();
    const std::int16_t* own = ct.data.data();
    const std::int16_t* smooth = hu.data();
    std::uint8_t* candidate = candidates.data.data();
    const std::size_t count = ct.size();
    for (std::size_t n = 0; n < count; ++n)
      candidate[n] =
          (in_body[n] != 0) & (by_cortex[n] == 0) & (own[n] >= low_hu) & (smooth[n] < max_pool_hu);
  }
  Mask cores;
  Mask opened = open_candidates(candidates, params, cores);
  // parts: 6-connected, with their size, level, spread, trunk core and cortex contact
  const RunTable runs = extract_runs(opened, false);
  const RunLabels labels = label_runs(g, runs);
  const std::vector<PartStats> stats = part_stats(ct, runs, labels, opened, near, hu, cores);
  opened = Mask{};  // its parts are in the runs; each mask is released once used
  const double ml = segmentation::voxel_ml(g);
  std::vector<Verdict> verdicts(stats.size());
  const double cortical_hu = bone_seed_hu + params.cortex_margin_hu;  // only cortical bone
  for (std::size_t c = 0; c < stats.size(); ++c)
    verdicts[c] = judge(stats[c], soft_peak_hu, cortical_hu, ml, params);
  mark_marrow_parts(ct, runs, labels, cortex, cortical_hu, soft_peak_hu + params.min_contrast_hu,
                    params, verdicts);
  std::vector<std::uint8_t> keep(stats.size(), 0);
  std::size_t brightest = stats.size();  // the phase's lumen: an organ never outshines it
  for (std::size_t c = 0; c < stats.size(); ++c) {
    const PartStats& s = stats[c];
    count_verdict(verdicts[c], result);
    if (verdicts[c] != Verdict::lumen) continue;
    keep[c] = 1;
    if (brightest == stats.size() || s.mean() > stats[brightest].mean()) brightest = c;
  }
  if (brightest < stats.size()) {  // organs: below half the brightest lumen's height, no tube
    result.rejected_organ = drop_organs(g, runs, labels, stats, cores, soft_peak_hu,
                                        stats[brightest].mean(), params, keep);
    result.lumens -= result.rejected_organ;
  }
  segmentation::rewrite_runs(
      g, runs, labels, [&](std::int64_t c) { return keep[c]; }, result.lumen);
  // edges within two voxels of cortex (a face from `near`)
  trim_by_cortex(runs, labels, stats, keep, hu, near, soft_peak_hu, result.lumen);
  // rejoin: the branches and thin pieces the opening cut, grown from the lumens through the
  // candidates, never within a voxel of a part judged not a lumen
  Mask other(g, 0, "not lumens");
  segmentation::rewrite_runs(
      g, runs, labels, [&](std::int64_t c) { return !keep[c]; }, other);
  // ... nor within two voxels of cortex: cancellous bone's thin pieces lie between trabeculae
  grow_within(result.lumen, [&](std::size_t n) {
    return candidates.data[n] && !within_a_face(other, n) && !within_a_face(near, n);
  });
  candidates = Mask{};
  other = Mask{};
  if (brightest == stats.size()) return result;  // no lumen: phase none
  result.lumen_level_hu = stats[brightest].mean();
  Mask trunks(g, 0, "trunk cores");  // the kept lumens' cores
  segmentation::rewrite_runs(
      g, runs, labels, [&](std::int64_t c) { return keep[c]; }, trunks);
  keep_trunk_cores(cores, trunks);
  cores = Mask{};
  const ContrastPhase phase =
      read_contrast_phase(trunks, hu, soft_peak_hu, result.lumen_level_hu, params);
  result.contrast_phase = phase.name;
  result.second_trunk_level_hu = phase.second_trunk_hu;
  // branches: the lumens grown through voxels at their contrast, apart from cortex
  result.tube_level_hu = phase.tube_hu;
  if (params.find_branches)
    grow_branches(ct, body, hu, cortex, soft_peak_hu, result.lumen_level_hu,
                  std::max(result.lumen_level_hu, result.tube_level_hu), cortical_hu, params,
                  result.lumen);
  close_lumens(ct, body, cortex, near, hu, low_hu, max_pool_hu, params, result.lumen);
  // marrow: lumen voxels walled in by cortex on all six axis rays are the bone's
  const Mask walled_in = enclosed_by_cortex(ct, result.lumen, cortex, cortical_hu,
                                            soft_peak_hu + params.min_contrast_hu,
                                            params.marrow_enclosure_mm, kWalledInSides);
  remove(walled_in, result.lumen);
  // outline: the tissue inside a lumen's round, fat-bound outline (a false lumen, the wall)
  fill_round_outlines(ct, cortex, 0.5 * (params.fat_peak_hu + soft_peak_hu), cortical_hu, params,
                      result.lumen);
  result.voxels = segmentation::count_nonzero(result.lumen);
  return result;
}

}  // namespace

VesselResult segment_vessels(const CtVolume& ct, const Mask& body, double soft_peak_hu,
                             double bone_seed_hu, const VesselParams& params) {
  check(ct, body, soft_peak_hu, params);
  const segmentation::VoxelBox box = vessel_search_box(ct, body, soft_peak_hu, params);
  if (!box_saves_a_tenth(box, ct.size()))  // none, or no gain
    return search_vessels(ct, body, soft_peak_hu, bone_seed_hu, params);
  VesselResult result =
      search_vessels(crop(ct, box), crop(body, box), soft_peak_hu, bone_seed_hu, params);
  Mask lumen(ct.grid, 0, "vessel mask");
  paste(result.lumen, box, lumen);
  result.lumen = std::move(lumen);
  return result;
}

}  // namespace palp
