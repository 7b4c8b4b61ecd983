// Signed distance maps: exact equality with a brute-force search, analytic bounds for a sphere
// and a box, and the sign and h/2 offset at the boundary (spec "Masks and distance maps").
#include "prep/maps/distance_transform.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

#include "base/errors.hpp"

namespace palp {
namespace {

Mask make_mask(Index3 dims, Vec3 spacing) {
  Grid grid;
  grid.dims = dims;
  grid.spacing = spacing;
  return Mask(grid, 0);
}

// The definition, evaluated by visiting every pair of voxels: the squared distance between voxel
// centres is sum over axes of (index difference)^2 * spacing^2.
DistanceMap brute_force(const Mask& mask, double band) {
  const Grid& g = mask.grid;
  const double h = g.min_spacing();
  const double s2[3] = {g.spacing[0] * g.spacing[0], g.spacing[1] * g.spacing[1],
                        g.spacing[2] * g.spacing[2]};
  DistanceMap out(g, 0.0f);
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const bool inside = mask.at(i, j, k) != 0;
        double best = std::numeric_limits<double>::infinity();
        for (std::int64_t kk = 0; kk < g.dims[2]; ++kk)
          for (std::int64_t jj = 0; jj < g.dims[1]; ++jj)
            for (std::int64_t ii = 0; ii < g.dims[0]; ++ii) {
              if ((mask.at(ii, jj, kk) != 0) == inside) continue;
              const double a = static_cast<double>(i - ii), b = static_cast<double>(j - jj),
                           c = static_cast<double>(k - kk);
              best = std::min(best, a * a * s2[0] + b * b * s2[1] + c * c * s2[2]);
            }
        float d = static_cast<float>(band);
        if (std::isfinite(best)) d = std::min(d, static_cast<float>(std::sqrt(best) - h / 2.0));
        out.at(i, j, k) = inside ? d : -d;
      }
  return out;
}

TEST(SignedDistance, EqualsBruteForceOnRandomAnisotropicMasks) {
  std::mt19937 rng(12345);
  const Vec3 spacings[] = {{1.0, 1.0, 1.0}, {0.8, 0.8, 1.5}, {0.7, 1.3, 2.9}, {3.0, 0.5, 1.0}};
  int case_index = 0;
  for (const Vec3& spacing : spacings) {
    for (double fill : {0.05, 0.3, 0.5, 0.9}) {
      std::uniform_int_distribution<int> dim(1, 13);
      Mask mask = make_mask({dim(rng), dim(rng), dim(rng)}, spacing);
      std::bernoulli_distribution inside(fill);
      for (auto& v : mask.data) v = inside(rng) ? 1 : 0;
      const double band = 1e6;  // no clamping: every value is compared
      const DistanceMap expected = brute_force(mask, band);
      for (unsigned threads : {1u, 2u, 3u}) {
        const DistanceMap got = signed_distance(mask, {band, threads});
        ASSERT_EQ(got.grid, mask.grid);
        for (std::size_t v = 0; v < got.size(); ++v) {
          ASSERT_EQ(got.data[v], expected.data[v])
              << "case " << case_index << " voxel " << v << " threads " << threads;
        }
      }
      ++case_index;
    }
  }
}

// One side: its voxels exactly as the definition gives them (with the band's clamp and the
// crop), the other side's only signed right (<= 0 outside, >= 0 inside).
TEST(SignedDistance, OneSideEqualsBruteForceOnItsVoxels) {
  std::mt19937 rng(2026);
  const Vec3 spacings[] = {{1.0, 1.0, 1.0}, {0.8, 0.8, 1.5}, {0.7, 1.3, 2.9}};
  int case_index = 0;
  for (const Vec3& spacing : spacings) {
    for (double fill : {0.03, 0.3, 0.9}) {
      for (double band : {1e6, 2.5}) {
        std::uniform_int_distribution<int> dim(1, 17);
        Mask mask = make_mask({dim(rng), dim(rng), dim(rng)}, spacing);
        std::bernoulli_distribution inside(fill);
        for (auto& v : mask.data) v = inside(rng) ? 1 : 0;
        const DistanceMap expected = brute_force(mask, band);
        for (DistanceSide side : {DistanceSide::inside, DistanceSide::outside}) {
          for (unsigned threads : {1u, 2u}) {
            const DistanceMap got = signed_distance(mask, {band, threads, side});
            for (std::size_t v = 0; v < got.size(); ++v) {
              const bool in = mask.data[v] != 0;
              if (in == (side == DistanceSide::inside))
                ASSERT_EQ(got.data[v], expected.data[v]) << "case " << case_index << " " << v;
              else if (in)
                ASSERT_GE(got.data[v], 0.0f) << "case " << case_index << " " << v;
              else
                ASSERT_LE(got.data[v], 0.0f) << "case " << case_index << " " << v;
            }
          }
        }
        ++case_index;
      }
    }
  }
}

TEST(SignedDistance, EqualsBruteForceWithBandClampAndCrop) {
  // A small object in a larger grid: the crop and the clamp both act.
  Mask mask = make_mask({40, 9, 7}, {0.5, 1.0, 2.0});
  mask.at(20, 4, 3) = mask.at(21, 4, 3) = mask.at(21, 5, 3) = mask.at(22, 5, 4) = 1;
  for (double band : {0.7, 2.0, 5.5}) {
    const DistanceMap expected = brute_force(mask, band);
    const DistanceMap got = signed_distance(mask, {band, 2});
    for (std::size_t v = 0; v < got.size(); ++v) ASSERT_EQ(got.data[v], expected.data[v]) << v;
  }
}

TEST(SignedDistance, SignAndHalfVoxelOffsetAtTheBoundary) {
  // Half-space i < 5 inside, 2 mm voxels: the surface lies half way between i = 4 and i = 5.
  Mask mask = make_mask({10, 3, 3}, {2.0, 2.0, 2.0});
  for (std::int64_t k = 0; k < 3; ++k)
    for (std::int64_t j = 0; j < 3; ++j)
      for (std::int64_t i = 0; i < 5; ++i) mask.at(i, j, k) = 1;
  const DistanceMap d = signed_distance(mask, {60.0, 1});
  for (std::int64_t i = 0; i < 10; ++i) {
    // Exact distance to the plane x = 9 mm, positive inside.
    const double expected = 9.0 - 2.0 * static_cast<double>(i);
    EXPECT_FLOAT_EQ(d.at(i, 1, 1), static_cast<float>(expected)) << i;
  }
  // Linear interpolation between the two voxels either side crosses zero on the surface.
  EXPECT_FLOAT_EQ(0.5f * (d.at(4, 1, 1) + d.at(5, 1, 1)), 0.0f);
}

TEST(SignedDistance, OffsetUsesTheSmallestSpacing) {
  Mask mask = make_mask({1, 1, 6}, {0.5, 0.5, 3.0});
  mask.at(0, 0, 0) = mask.at(0, 0, 1) = mask.at(0, 0, 2) = 1;
  const DistanceMap d = signed_distance(mask, {60.0, 1});
  EXPECT_FLOAT_EQ(d.at(0, 0, 2), 3.0f - 0.25f);
  EXPECT_FLOAT_EQ(d.at(0, 0, 3), -(3.0f - 0.25f));
  EXPECT_FLOAT_EQ(d.at(0, 0, 0), 9.0f - 0.25f);
}

TEST(SignedDistance, SphereWithinAnalyticBound) {
  // Voxelised ball of radius R. For a voxel centre at true signed distance t from the sphere:
  //   inside:  t - h/2 < D <= t + (sqrt(3) - 1/2) h      (and symmetrically outside)
  // because the nearest opposite voxel centre lies beyond the sphere, and some opposite voxel
  // centre lies within sqrt(3)/2 h of the point sqrt(3)/2 h past the surface.
  const double h = 1.0, radius = 17.3;
  const Vec3 centre{25.4, 24.7, 25.1};
  Mask mask = make_mask({51, 50, 52}, {h, h, h});
  for (std::int64_t k = 0; k < 52; ++k)
    for (std::int64_t j = 0; j < 50; ++j)
      for (std::int64_t i = 0; i < 51; ++i) {
        const double r = std::hypot(i * h - centre[0], j * h - centre[1], k * h - centre[2]);
        mask.at(i, j, k) = r <= radius ? 1 : 0;
      }
  const DistanceMap d = signed_distance(mask, {60.0, 2});
  double worst_low = 0.0, worst_high = 0.0;
  for (std::int64_t k = 0; k < 52; ++k)
    for (std::int64_t j = 0; j < 50; ++j)
      for (std::int64_t i = 0; i < 51; ++i) {
        const double r = std::hypot(i * h - centre[0], j * h - centre[1], k * h - centre[2]);
        const double t = radius - r;  // positive inside
        const double err = (mask.at(i, j, k) ? 1.0 : -1.0) * (d.at(i, j, k) - t);
        worst_low = std::min(worst_low, err);
        worst_high = std::max(worst_high, err);
      }
  EXPECT_GT(worst_low, -h / 2.0 - 1e-5);
  EXPECT_LE(worst_high, (std::sqrt(3.0) - 0.5) * h + 1e-5);
}

TEST(SignedDistance, BoxFacesAreExactAndCornersBounded) {
  // Box of voxels [5, 24] x [4, 15] x [3, 12] at 1 mm: its surface lies half a voxel outside
  // the outer voxel centres. Inside, D is the exact distance to the nearest face. Outside, D is
  // exact in front of a face and within (sqrt(3) - 1) h / 2 of the analytic distance elsewhere.
  const Index3 lo{5, 4, 3}, hi{24, 15, 12};
  Mask mask = make_mask({30, 20, 16}, {1.0, 1.0, 1.0});
  for (std::int64_t k = lo[2]; k <= hi[2]; ++k)
    for (std::int64_t j = lo[1]; j <= hi[1]; ++j)
      for (std::int64_t i = lo[0]; i <= hi[0]; ++i) mask.at(i, j, k) = 1;
  const DistanceMap d = signed_distance(mask, {60.0, 2});
  for (std::int64_t k = 0; k < 16; ++k)
    for (std::int64_t j = 0; j < 20; ++j)
      for (std::int64_t i = 0; i < 30; ++i) {
        const std::int64_t p[3] = {i, j, k};
        double outside2 = 0.0, inside_min = std::numeric_limits<double>::infinity();
        int axes_out = 0;
        for (int a = 0; a < 3; ++a) {
          const double below = (lo[a] - 0.5) - p[a], above = p[a] - (hi[a] + 0.5);
          const double gap = std::max(below, above);
          if (gap > 0) {
            outside2 += gap * gap;
            ++axes_out;
          }
          inside_min = std::min(inside_min, -gap);
        }
        if (mask.at(i, j, k)) {
          EXPECT_FLOAT_EQ(d.at(i, j, k), static_cast<float>(inside_min))
              << i << "," << j << "," << k;
        } else if (axes_out == 1) {
          EXPECT_FLOAT_EQ(d.at(i, j, k), static_cast<float>(-std::sqrt(outside2)));
        } else {
          const double err = -d.at(i, j, k) - std::sqrt(outside2);
          EXPECT_GE(err, -1e-5);
          EXPECT_LE(err, (std::sqrt(3.0) - 1.0) / 2.0 + 1e-5);
        }
      }
}

TEST(SignedDistance, EmptyAndFullMasksAreClampedToTheBand) {
  Mask empty = make_mask({4, 5, 6}, {1.0, 2.0, 3.0});
  for (float v : signed_distance(empty, {12.5, 1}).data) ASSERT_EQ(v, -12.5f);
  Mask full = empty;
  std::fill(full.data.begin(), full.data.end(), 1);
  for (float v : signed_distance(full, {12.5, 1}).data) ASSERT_EQ(v, 12.5f);
}

TEST(SignedDistance, ReusedOutputEqualsAFreshOne) {
  std::mt19937 rng(7);
  std::bernoulli_distribution inside(0.4);
  Mask first = make_mask({23, 17, 11}, {0.9, 1.1, 2.0});
  Mask second = first;
  for (auto& v : first.data) v = inside(rng);
  for (auto& v : second.data) v = inside(rng);
  second.grid.world.origin = {1.0, 2.0, 3.0};
  DistanceMap reused;
  signed_distance(first, {4.0, 2}, reused);
  signed_distance(second, {4.0, 2}, reused);
  const DistanceMap fresh = signed_distance(second, {4.0, 2});
  EXPECT_EQ(reused.grid, fresh.grid);
  EXPECT_EQ(reused.data, fresh.data);
}

TEST(SignedDistance, RejectsANonPositiveBand) {
  Mask mask = make_mask({2, 2, 2}, {1.0, 1.0, 1.0});
  EXPECT_THROW(signed_distance(mask, {0.0, 1}), UsageError);
  EXPECT_THROW(signed_distance(mask, {std::nan(""), 1}), UsageError);
}

TEST(DistanceTransform, AbsurdBandsAreRefused) {
  Grid g;
  g.dims = {4, 4, 4};
  const Mask mask(g);
  DistanceParams p;
  for (double band : {0.0, -1.0, 1e308, std::nan("")}) {
    p.band_mm = band;
    EXPECT_THROW(signed_distance(mask, p), UsageError) << band;
  }
  p.band_mm = 1e6;  // "no clamping"
  EXPECT_NO_THROW(signed_distance(mask, p));
}

}  // namespace
}  // namespace palp
