// Tests common/prep/maps/map_refine.cpp: the factors, the aligned grid, the upsampled map's
// interpolant against the coarse one's, and (with prep/maps/iso_projection) the refined skin map of
// a partial-volume sphere at 3 mm against the analytic distance.
#include "prep/maps/map_refine.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "base/errors.hpp"
#include "model/field_sampler.hpp"
#include "prep/maps/iso_projection.hpp"
#include "prep/maps/subvoxel_distance.hpp"
#include "support/partial_volume.hpp"

namespace palp {
namespace {

Grid grid_of(Index3 dims, Vec3 spacing) {
  Grid g;
  g.dims = dims;
  g.spacing = spacing;
  g.world.origin = {-120.5, 33.25, -807.0};
  g.world.direction = {0, 1, 0, -1, 0, 0, 0, 0, 1};
  return g;
}

TEST(MapRefine, FactorsFollowTheCoarsestSpacings) {
  // The real CT (3 mm): 2 per axis at 2 mm, 3 at 1 mm; its own grid at 0, the default.
  const Grid ct = grid_of({122, 101, 112}, {3.0, 3.0, 3.0});
  EXPECT_EQ(map_refinement(ct, kSuggestedMapSpacingMm), (Refinement{2, 2, 2}));
  EXPECT_EQ(map_refinement(ct, 1.0), (Refinement{3, 3, 3}));
  EXPECT_EQ(map_refinement(ct, 0.0), (Refinement{1, 1, 1}));
  EXPECT_EQ(map_refinement(ct, kDefaultMapSpacingMm), (Refinement{1, 1, 1}));
  EXPECT_FALSE(is_refined(map_refinement(ct, 0.0)));
  // The torso phantom (1.25 x 1.25 x 2 mm) and the prep benchmarks' grids are not refined.
  EXPECT_EQ(map_refinement(grid_of({384, 256, 96}, {1.25, 1.25, 2.0}), kSuggestedMapSpacingMm),
            (Refinement{1, 1, 1}));
  for (const double limit : {kSuggestedMapSpacingMm, 1.5}) {
    EXPECT_EQ(map_refinement(grid_of({384, 384, 160}, {0.8, 0.8, 1.5}), limit),
              (Refinement{1, 1, 1}));
    EXPECT_EQ(map_refinement(grid_of({512, 512, 400}, {0.8, 0.8, 1.0}), limit),
              (Refinement{1, 1, 1}));
  }
  // Per axis: thick slices only along their axis; an axis of one voxel never.
  EXPECT_EQ(map_refinement(grid_of({64, 64, 20}, {0.7, 0.7, 5.0}), 2.0), (Refinement{1, 1, 3}));
  EXPECT_EQ(map_refinement(grid_of({64, 1, 20}, {3.0, 3.0, 3.0}), 2.0), (Refinement{2, 1, 2}));
  // Within the cap: a 512 x 512 x 80 CT at 0.7 x 0.7 x 5 mm would take 3 x 21 M nodes; lowered.
  const Grid thick = grid_of({512, 512, 80}, {0.7, 0.7, 5.0});
  const Refinement capped = map_refinement(thick, 2.0);
  EXPECT_EQ(capped, (Refinement{1, 1, 2}));
  EXPECT_LE(refined_grid(thick, capped).voxel_count(), kMaxRefinedVoxels);
}

TEST(MapRefine, RefinedGridIsAlignedWithTheCoarse) {
  const Grid ct = grid_of({7, 5, 4}, {3.0, 2.5, 3.0});
  const Grid fine = refined_grid(ct, {2, 3, 1});
  EXPECT_EQ(fine.dims, (Index3{13, 13, 4}));
  EXPECT_DOUBLE_EQ(fine.spacing[0], 1.5);
  EXPECT_DOUBLE_EQ(fine.spacing[1], 2.5 / 3.0);
  EXPECT_DOUBLE_EQ(fine.spacing[2], 3.0);
  EXPECT_EQ(fine.world, ct.world);
  // The same extent: the scene frame does not move.
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(fine.extent_mm()[a], ct.extent_mm()[a], 1e-12);
  EXPECT_EQ(refinement_between(ct, fine), (Refinement{2, 3, 1}));
  EXPECT_EQ(refinement_between(ct, ct), (Refinement{1, 1, 1}));
  Grid moved = fine;
  moved.world.origin[0] += 1.0;
  EXPECT_EQ(refinement_between(ct, moved), (Refinement{0, 0, 0}));
  Grid odd = fine;
  odd.dims[0] = 14;
  EXPECT_EQ(refinement_between(ct, odd), (Refinement{0, 0, 0}));
  EXPECT_THROW(refined_grid(ct, {0, 1, 1}), UsageError);
}

// Trilinear upsampling at aligned nodes is the coarse map's interpolant: equal at the aligned
// nodes bit for bit, and at random points to the float rounding of the new nodes.
TEST(MapRefine, UpsampledInterpolantEqualsTheCoarseOne) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> value(-60.0f, 60.0f);
  const Grid g = grid_of({9, 7, 6}, {3.0, 2.0, 2.5});
  DistanceMap coarse(g, 0.0f, "coarse");
  for (float& v : coarse.data) v = value(rng);
  for (const Refinement k : {Refinement{2, 2, 2}, Refinement{3, 3, 3}, Refinement{1, 4, 2}}) {
    const DistanceMap fine = upsample_aligned(coarse, k);
    ASSERT_EQ(fine.grid, refined_grid(g, k));
    for (std::int64_t kk = 0; kk < g.dims[2]; ++kk)
      for (std::int64_t j = 0; j < g.dims[1]; ++j)
        for (std::int64_t i = 0; i < g.dims[0]; ++i)
          ASSERT_EQ(fine.at(i * k[0], j * k[1], kk * k[2]), coarse.at(i, j, kk));
    const FieldSampler a(coarse), b(fine);
    std::uniform_real_distribution<double> ux(0.0, 24.0), uy(0.0, 12.0), uz(0.0, 12.5);
    double worst = 0.0, worst_grad = 0.0;
    for (int n = 0; n < 20000; ++n) {
      const Vec3d x{ux(rng), uy(rng), uz(rng)};
      const FieldSample sa = a.sample_surf(x), sb = b.sample_surf(x);
      ASSERT_TRUE(sa.inside && sb.inside);
      worst = std::max(worst, std::abs(sa.value - sb.value));
      worst_grad = std::max(worst_grad, norm(sa.grad - sb.grad));
    }
    // Nodes hold floats: |D| <= 60 mm rounds by <= 60 * 2^-24 = 3.6e-6 mm.
    EXPECT_LE(worst, 4e-6) << k[0] << k[1] << k[2];
    // The analytic gradient too, up to that rounding over a fine cell (>= 0.5 mm).
    EXPECT_LE(worst_grad, 2e-5) << k[0] << k[1] << k[2];
  }
}

// A sphere of radius 30 mm in partial volume on 3 mm voxels (HU -1000 outside, 0 inside, the
// voxel's covered fraction between, 6^3 samples a voxel): the skin map at depths 1.5-6 mm,
// sampled trilinearly at random points (not nodes), on the CT's grid and refined by 2 and 3
// (nodes in the band projected onto the trilinear HU's surface), against the exact distance to
// that surface (what the map stands for) and against the analytic distance R - r (which adds the
// partial-volume surface's own offset from the sphere, ~0.1 mm, that no map removes).
TEST(MapRefine, RefinedSkinMapOfAPartialVolumeSphereIsCloserToTheExactDistance) {
  constexpr double h = 3.0, radius = 30.0, iso = -500.0;
  constexpr std::int64_t n = 28;
  const Grid g = grid_of({n, n, n}, {h, h, h});
  const Vec3d centre{40.3, 41.1, 39.6};
  const CtVolume ct = testing::partial_volume_balls(g, {{centre, radius, 0.0}}, -1000.0);
  Mask mask(g, 0, "mask");
  for (std::size_t v = 0; v < ct.data.size(); ++v) mask.data[v] = ct.data[v] >= iso ? 1 : 0;
  const SurfacePoints points = surface_points(ct, mask, iso);
  DistanceMap coarse;
  subvoxel_signed_distance(points, mask, 2.0 * h, 60.0, coarse);
  double rms_iso[3] = {0, 0, 0}, rms_sphere[3] = {0, 0, 0};
  for (int k = 1; k <= 3; ++k) {
    DistanceMap map = k == 1 ? coarse : upsample_aligned(coarse, {k, k, k});
    const IsoProjectionStats stats =
        project_onto_iso_surface(ct, mask, iso, 3.0 * h, h, 0.25 * h, 60.0, map);
    EXPECT_GE(stats.projected, stats.visited * 99 / 100) << k;
    const FieldSampler fields(map);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-1.0, 1.0), depth(1.5, 6.0);
    double sum2_iso = 0.0, sum2_sphere = 0.0;
    int count = 0;
    while (count < 3000) {
      Vec3d dir{u(rng), u(rng), u(rng)};
      if (!(norm(dir) > 0.1 && norm(dir) <= 1.0)) continue;
      dir = dir * (1.0 / norm(dir));
      const double d = depth(rng);
      const Vec3d x = centre + (radius - d) * dir;
      const double q[3] = {x.x, x.y, x.z};
      const Vec3d on = centre + radius * dir;
      double start[3] = {on.x, on.y, on.z};
      const double exact = distance_to_iso_surface(ct, iso, q, start);
      ASSERT_GE(exact, 0.0);
      const double value = fields.sample_surf(x).value;
      sum2_iso += (value - exact) * (value - exact);
      sum2_sphere += (value - d) * (value - d);
      ++count;
    }
    rms_iso[k - 1] = std::sqrt(sum2_iso / count);
    rms_sphere[k - 1] = std::sqrt(sum2_sphere / count);
    std::printf(
        "partial-volume sphere R 30 mm, 3 mm voxels, map refined by %d, 1.5-6 mm deep: "
        "against the exact distance to the trilinear iso-surface rms %.4f mm, against "
        "R - r rms %.4f mm\n",
        k, rms_iso[k - 1], rms_sphere[k - 1]);
  }
  // Measured: 0.094 / 0.038 / 0.021 mm (the interpolation error falls about as h^2), and
  // against R - r 0.182 / 0.162 / 0.162 mm.
  EXPECT_GE(rms_iso[0], 0.07);
  EXPECT_LE(rms_iso[1], 0.5 * rms_iso[0]);
  EXPECT_LE(rms_iso[1], 0.05);
  EXPECT_LE(rms_iso[2], 0.7 * rms_iso[1]);
  EXPECT_LE(rms_sphere[1], rms_sphere[0]);
  EXPECT_LE(rms_sphere[2], rms_sphere[0]);
}

}  // namespace
}  // namespace palp
