// Branches and walled-in marrow (see vessel_branches.hpp). Data flow:
//   walls      a voxel, `of` -> six axis rays through `of` -> cortex met on how many sides
//   enclosed   a mask -> its voxels the walls enclose (every voxel judged)
//   branches   lumens -> grown through the branch band, which is judged voxel by voxel where
//              the growth reaches (HU band, clearance from cortical HU, ridge fence, walls), each
//              voxel once
//   ends       the band on the scan's end slices, not walled in across the body axis -> pieces
//              no wider than a trunk's core, no denser than the lumen -> grown through the band
//              -> kept where a tube as big as a lumen -> lumens
#include "prep/vessel/vessel_branches.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <numbers>
#include <vector>

#include "base/parallel.hpp"
#include "prep/bone/bone_islands.hpp"
#include "prep/segment/components.hpp"
#include "prep/segment/morphology.hpp"
#include "prep/segment/segmentation.hpp"
#include "prep/segment/slice_planes.hpp"
#include "prep/vessel/vessel_phase.hpp"

namespace palp {
namespace {

// Sides (of the six axis directions) on which cortex walls a voxel in for it to be marrow: a
// vertebral body's or a long bone's marrow is walled in on all six (endplates above and below)
// but where a blurred cortex leaves a gap; a lumen runs on along its length (two sides open,
// however calcified its wall) and a lumen resting on bone is walled in on one.
constexpr int kEnclosedSides = 5;
// A seed on the scan's end slice is marrow when cortex meets this many of its four in-plane rays:
// the rays along the body axis say nothing there (one leaves the scan, and a phantom's or a
// blurred spine need show no endplate within reach); a vessel lying on a rib meets it on one.
constexpr int kSeedInPlaneSides = 3;

// Cortex walls voxel n of `of` (see enclosed_by_cortex) in on `min_sides` of the six axis rays;
// `of(m)` says whether voxel m is one of them. Stops once the rays left cannot make min_sides.
class CortexWalls {
 public:
  // `skip_axis` (0-2): the two rays along it are not cast (min_sides then counts of four).
  CortexWalls(const CtVolume& ct, const Mask& ridge, double cortex_hu, double through_hu,
              double reach_mm, int min_sides, int skip_axis = -1)
      : ct_(ct),
        ridge_(ridge),
        cortex_hu_(cortex_hu),
        through_hu_(through_hu),
        min_sides_(min_sides),
        skip_axis_(skip_axis) {
    for (int a = 0; a < 3; ++a)
      reach_[a] = static_cast<std::int64_t>(std::lround(reach_mm / ct.grid.spacing[a]));
  }

  template <class Of>
  bool around(std::int64_t n, const std::int64_t (&at)[3], Of of) const {
    const Grid& g = ct_.grid;
    const std::int64_t stride[3] = {1, g.dims[0], g.dims[0] * g.dims[1]};
    const int rays = skip_axis_ < 0 ? 6 : 4;
    int sides = 0, open = 0;  // rays that met cortex / did not
    for (int r = 0; r < 6 && open <= rays - min_sides_; ++r) {
      const int a = r / 2, d = r % 2 == 0 ? -1 : 1;
      if (a == skip_axis_) continue;
      bool met = false;
      for (std::int64_t s = 1; s <= reach_[a]; ++s) {
        const std::int64_t q = at[a] + d * s;
        if (q < 0 || q >= g.dims[a]) break;
        const std::int64_t m = n + d * s * stride[a];
        if (of(m)) continue;  // through the voxels judged, however bright
        if (ridge_.data[m] || ct_.data[m] >= cortex_hu_) {
          met = true;
          break;
        }
        if (ct_.data[m] < through_hu_) break;
      }
      sides += met;
      open += !met;
    }
    return sides >= min_sides_;
  }

 private:
  const CtVolume& ct_;
  const Mask& ridge_;
  double cortex_hu_, through_hu_;
  int min_sides_, skip_axis_;
  std::int64_t reach_[3];  // voxels along each axis
};

// The branch band (see grow_branches), judged only where the growth reaches, each voxel once:
// the growth from the lumens touches a small part of the grid.
class BranchBand {
 public:
  BranchBand(const CtVolume& ct, const Mask& body, const std::vector<std::int16_t>& hu,
             const Mask& ridge, double soft_hu, double lumen_hu, double cortex_hu,
             const VesselParams& params)
      : ct_(ct),
        body_(body),
        hu_(hu),
        ridge_(ridge),
        cortex_hu_(cortex_hu),
        fence_(params.branch_fence_ridge_directions),
        walls_(ct, ridge, cortex_hu, soft_hu + params.min_contrast_hu, params.marrow_enclosure_mm,
               kEnclosedSides),
        in_plane_walls_(ct, ridge, cortex_hu, soft_hu + params.min_contrast_hu,
                        params.marrow_enclosure_mm, kSeedInPlaneSides, patient_axes(ct.grid).slice),
        state_(ct.size(), 0) {
    const Grid& g = ct.grid;
    const double h_min = std::min({g.spacing[0], g.spacing[1], g.spacing[2]});
    clearance_steps_ = static_cast<int>(std::lround(params.branch_clearance_mm / h_min));
    // The lumen's edge (half way from the soft tissue to its level), never below a lumen's
    // least contrast (an enhancing organ of a portal-venous phase stays out), up to half its
    // height above it (noise in a lumen; denser is something else).
    const double height = lumen_hu - soft_hu;
    low_ = std::max(soft_hu + 0.5 * height, soft_hu + params.min_lumen_contrast_hu);
    high_ = lumen_hu + 0.5 * height;
  }

  // In the band and not walled in by cortex as marrow is.
  bool allowed(std::int64_t n) {
    if (!in_band(n)) return false;
    std::uint8_t& s = state_[static_cast<std::size_t>(n)];
    if ((s & kWallsJudged) == 0) {
      const Index3 at = index_of(n);
      const bool walled =
          walls_.around(n, {at[0], at[1], at[2]}, [this](std::int64_t m) { return in_band(m); });
      s |= kWallsJudged | (walled ? kWalled : 0);
    }
    return (s & kWalled) == 0;
  }

  // Allowed, and not walled in by cortex across the body axis (kSeedInPlaneSides).
  bool allowed_as_seed(std::int64_t n) {
    if (!allowed(n)) return false;
    const Index3 at = index_of(n);
    return !in_plane_walls_.around(n, {at[0], at[1], at[2]},
                                   [this](std::int64_t m) { return in_band(m); });
  }

 private:
  static constexpr std::uint8_t kBandJudged = 1, kInBand = 2, kWallsJudged = 4, kWalled = 8;

  Index3 index_of(std::int64_t n) const {
    const std::int64_t nx = ct_.grid.dims[0], ny = ct_.grid.dims[1];
    return {n % nx, (n / nx) % ny, n / (nx * ny)};
  }

  // Body, smoothed HU in the lumen's band, own HU below cortex, no cortical voxel within the
  // clearance, not a shell's ridge.
  bool in_band(std::int64_t n) {
    std::uint8_t& s = state_[static_cast<std::size_t>(n)];
    if ((s & kBandJudged) == 0) {
      const auto v = static_cast<std::size_t>(n);
      const bool in = body_.data[v] && hu_[v] >= low_ && hu_[v] <= high_ &&
                      ridge_.data[v] < fence_ && !cortex_within_clearance(n);
      s |= kBandJudged | (in ? kInBand : 0);
    }
    return (s & kInBand) != 0;
  }

  // A voxel at or above cortex_hu within clearance_steps_ face steps (the grid is a box, so a
  // path of that many face steps reaches every voxel that near by the city-block measure).
  bool cortex_within_clearance(std::int64_t n) const {
    const Grid& g = ct_.grid;
    const Index3 at = index_of(n);
    const int r = clearance_steps_;
    for (int dk = -r; dk <= r; ++dk) {
      const std::int64_t k = at[2] + dk;
      if (k < 0 || k >= g.dims[2]) continue;
      const int rj = r - std::abs(dk);
      for (int dj = -rj; dj <= rj; ++dj) {
        const std::int64_t j = at[1] + dj;
        if (j < 0 || j >= g.dims[1]) continue;
        const int ri = rj - std::abs(dj);
        const std::int64_t i0 = std::max<std::int64_t>(0, at[0] - ri);
        const std::int64_t i1 = std::min<std::int64_t>(g.dims[0] - 1, at[0] + ri);
        const std::int16_t* row = &ct_.data[g.linear(0, j, k)];
        for (std::int64_t i = i0; i <= i1; ++i)
          if (row[i] >= cortex_hu_) return true;
      }
    }
    return false;
  }

  const CtVolume& ct_;
  const Mask& body_;
  const std::vector<std::int16_t>& hu_;
  const Mask& ridge_;
  double cortex_hu_;
  int fence_;
  CortexWalls walls_, in_plane_walls_;
  int clearance_steps_ = 0;
  double low_ = 0.0, high_ = 0.0;
  std::vector<std::uint8_t> state_;  // per voxel: the kBandJudged ... kWalled bits
};

// Keeps the 6-connected pieces of `seeds` (on the scan's end slices) that can be a branch: no
// wider than pi * trunk_core_mm^2 across the body axis (a wider piece would hold a trunk's core
// and have been judged as a part already: a vertebral body, a rib's marrow cut lengthwise), and
// on average (smoothed HU) no denser than the blood that fills the lumens (`blood_hu`): partial
// volume only darkens a thinner vessel, while marrow and blurred cortex at the scan's end are
// denser than the contrast.
void keep_branch_like_pieces(const std::vector<std::int16_t>& hu, double blood_hu,
                             const VesselParams& params, Mask& seeds) {
  const Grid& g = seeds.grid;
  const int slice = patient_axes(g).slice;
  const double voxel_mm2 = g.spacing[0] * g.spacing[1] * g.spacing[2] / g.spacing[slice];
  const double max_mm2 = std::numbers::pi * params.trunk_core_mm * params.trunk_core_mm;
  const segmentation::RunTable runs = segmentation::extract_runs(seeds, false);
  const segmentation::RunLabels labels = segmentation::label_runs(g, runs);
  const std::vector<std::int64_t> sum = segmentation::sum_per_component(
      g, runs, labels, [&](std::size_t n) -> std::int64_t { return hu[n]; });
  segmentation::rewrite_runs(
      g, runs, labels,
      [&](std::int64_t c) {
        const auto k = static_cast<std::size_t>(c);
        const auto voxels = static_cast<double>(labels.voxels[k]);
        return voxels * voxel_mm2 <= max_mm2 && static_cast<double>(sum[k]) / voxels <= blood_hu;
      },
      seeds);
}

// Branches the scan's end cuts off from their trunk (the subclavian above a chest crop): the
// band's voxels on the first and last slice along the body axis that are no marrow across it
// (BranchBand::allowed_as_seed), in pieces that can be a branch (keep_branch_like_pieces), grown
// through the band beside `lumen`; what grows from them is kept where it is as big as a lumen
// (min_lumen_ml) and a tube (vessel_phase.hpp): marrow grown from the scan's end is a blob.
void grow_from_the_scans_ends(const std::vector<std::int16_t>& hu, double blood_hu,
                              const VesselParams& params, BranchBand& band, Mask& lumen) {
  const Grid& g = lumen.grid;
  const PatientAxes axes = patient_axes(g);
  Mask seeded(g, 0, "branch seeds");
  for (std::int64_t w : {std::int64_t{0}, g.dims[axes.slice] - 1}) {
    const segmentation::Plane p = segmentation::axial_plane(g, axes, w);
    for (std::int64_t v = 0; v < p.nv; ++v)
      for (std::int64_t u = 0; u < p.nu; ++u) {
        const std::size_t n = p.at(u, v);
        seeded.data[n] = !lumen.data[n] && band.allowed_as_seed(static_cast<std::int64_t>(n));
      }
  }
  keep_branch_like_pieces(hu, blood_hu, params, seeded);
  segmentation::grow_within(seeded, [&](std::size_t n) {
    return !lumen.data[n] && band.allowed(static_cast<std::int64_t>(n));
  });
  const segmentation::RunTable runs = segmentation::extract_runs(seeded, false);
  const segmentation::RunLabels labels = segmentation::label_runs(g, runs);
  const std::vector<segmentation::IslandShape> shapes =
      segmentation::island_shapes(g, runs, labels);
  const double ml = segmentation::voxel_ml(g);
  segmentation::rewrite_runs(
      g, runs, labels,
      [&](std::int64_t c) {
        const auto k = static_cast<std::size_t>(c);
        return static_cast<double>(labels.voxels[k]) * ml >= params.min_lumen_ml &&
               is_tube(shapes[k].sd, params.trunk_core_mm);
      },
      seeded);
  segmentation::unite(seeded, lumen);
}

}  // namespace

Mask enclosed_by_cortex(const CtVolume& ct, const Mask& of, const Mask& ridge, double cortex_hu,
                        double through_hu, double reach_mm, int min_sides) {
  const Grid& g = ct.grid;
  Mask enclosed(g, 0, "enclosed by cortex");
  const CortexWalls walls(ct, ridge, cortex_hu, through_hu, reach_mm, min_sides);
  const auto in_of = [&](std::int64_t m) { return of.data[m] != 0; };
  parallel_for_chunks(g.dims[2], 2, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t k = k0; k < k1; ++k)
      for (std::int64_t j = 0; j < g.dims[1]; ++j)
        for (std::int64_t i = 0; i < g.dims[0]; ++i) {
          const auto n = static_cast<std::int64_t>(g.linear(i, j, k));
          if (of.data[n]) enclosed.data[n] = walls.around(n, {i, j, k}, in_of);
        }
  });
  return enclosed;
}

void grow_branches(const CtVolume& ct, const Mask& body, const std::vector<std::int16_t>& hu,
                   const Mask& ridge, double soft_hu, double lumen_hu, double blood_hu,
                   double cortex_hu, const VesselParams& params, Mask& lumen) {
  BranchBand band(ct, body, hu, ridge, soft_hu, lumen_hu, cortex_hu, params);
  segmentation::grow_within(
      lumen, [&](std::size_t n) { return band.allowed(static_cast<std::int64_t>(n)); });
  grow_from_the_scans_ends(hu, blood_hu, params, band, lumen);
}

}  // namespace palp
