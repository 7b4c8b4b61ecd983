// Sub-voxel distance maps against analytic distances: a sphere and a tilted slab rendered with
// partial volume (HU = -1000 + 1000 x the voxel's covered fraction, supersampled, plus noise) at
// 1, 2 and 3 mm voxels; both surface methods are measured within 10 mm of the surface.
#include "prep/maps/subvoxel_distance.hpp"
#include "prep/maps/iso_projection.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <random>

#include "base/errors.hpp"
#include "prep/maps/distance_transform.hpp"

namespace palp {
namespace {

constexpr double kIso = -500.0;
constexpr double kNoiseHu = 20.0;
constexpr double kMeasureMm = 10.0;

// A shape: signed distance (mm, positive inside) of a point in grid mm.
using Shape = std::function<double(double, double, double)>;

struct Phantom {
  CtVolume ct;
  Mask mask;  // HU at or above the iso level, as the body segmentation thresholds
};

// Renders `shape` on an n^3 grid of spacing h: voxels within a half diagonal of the surface are
// supersampled 8^3 times, the others are wholly in or out.
Phantom render(const Shape& shape, std::int64_t n, double h, unsigned seed) {
  Grid grid;
  grid.dims = {n, n, n};
  grid.spacing = {h, h, h};
  Phantom p{CtVolume(grid, 0), Mask(grid, 0)};
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, kNoiseHu);
  constexpr int kSub = 8;
  const double half_diagonal = 0.5 * std::sqrt(3.0) * h;
  for (std::int64_t k = 0; k < n; ++k)
    for (std::int64_t j = 0; j < n; ++j)
      for (std::int64_t i = 0; i < n; ++i) {
        const double x = static_cast<double>(i) * h, y = static_cast<double>(j) * h,
                     z = static_cast<double>(k) * h;
        const double d = shape(x, y, z);
        double fraction = d > 0.0 ? 1.0 : 0.0;
        if (std::abs(d) < half_diagonal) {
          int covered = 0;
          for (int c = 0; c < kSub; ++c)
            for (int b = 0; b < kSub; ++b)
              for (int a = 0; a < kSub; ++a) {
                const double u = ((a + 0.5) / kSub - 0.5) * h, v = ((b + 0.5) / kSub - 0.5) * h,
                             w = ((c + 0.5) / kSub - 0.5) * h;
                covered += shape(x + u, y + v, z + w) > 0.0;
              }
          fraction = covered / static_cast<double>(kSub * kSub * kSub);
        }
        const double hu = std::clamp(-1000.0 + 1000.0 * fraction + noise(rng), -1024.0, 3000.0);
        p.ct.at(i, j, k) = static_cast<std::int16_t>(std::lround(hu));
        p.mask.at(i, j, k) = hu >= kIso ? 1 : 0;
      }
  return p;
}

struct Errors {
  double rms = 0.0;
  double max = 0.0;
  std::size_t count = 0;
};

// Errors of `map` against `shape` at voxels within kMeasureMm of the surface and at least
// `margin` mm from the grid's faces (nearer to them the nearest surface may lie off the grid).
Errors measure(const DistanceMap& map, const Shape& shape, double margin) {
  const Grid& g = map.grid;
  Errors e;
  double sum2 = 0.0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const double pos[3] = {static_cast<double>(i) * g.spacing[0],
                               static_cast<double>(j) * g.spacing[1],
                               static_cast<double>(k) * g.spacing[2]};
        bool interior = true;
        for (int a = 0; a < 3; ++a) {
          const double extent = static_cast<double>(g.dims[a] - 1) * g.spacing[a];
          interior = interior && pos[a] >= margin && pos[a] <= extent - margin;
        }
        if (!interior) continue;
        const double truth = shape(pos[0], pos[1], pos[2]);
        if (std::abs(truth) > kMeasureMm) continue;
        const double err = static_cast<double>(map.at(i, j, k)) - truth;
        sum2 += err * err;
        e.max = std::max(e.max, std::abs(err));
        ++e.count;
      }
  e.rms = e.count ? std::sqrt(sum2 / static_cast<double>(e.count)) : 0.0;
  return e;
}

struct Comparison {
  Errors mask, subvoxel, projected;
};

Comparison compare(const Shape& shape, double extent_mm, double h, double margin) {
  const auto n = static_cast<std::int64_t>(std::ceil(extent_mm / h)) + 1;
  const Phantom p = render(shape, n, h, 13u);
  DistanceParams params;
  params.band_mm = 60.0;
  Comparison c;
  DistanceMap map = signed_distance(p.mask, params);
  c.mask = measure(map, shape, margin);
  const SurfacePoints points = surface_points(p.ct, p.mask, kIso);
  subvoxel_signed_distance(points, p.mask, 2.0 * h, params.band_mm, map);  // prep's band
  c.subvoxel = measure(map, shape, margin);
  // and d_surf's projection onto the trilinear HU iso-surface, as prep does by default
  project_onto_iso_surface(p.ct, p.mask, kIso, 3.0 * h, h, 0.25 * h, params.band_mm, map);
  c.projected = measure(map, shape, margin);
  return c;
}

// A sphere of radius 25 mm, its centre off the voxel lattice.
Shape sphere(double extent_mm) {
  const double c = 0.5 * extent_mm + 0.37;
  return [c](double x, double y, double z) {
    const double dx = x - c, dy = y - (c - 0.61), dz = z - (c + 0.23);
    return 25.0 - std::sqrt(dx * dx + dy * dy + dz * dz);
  };
}

// A slab 40 mm thick through the centre, its normal tilted off every axis.
Shape slab(double extent_mm) {
  const double c = 0.5 * extent_mm;
  const double nx = 0.31, ny = 0.17, nz = 0.93, norm = std::sqrt(nx * nx + ny * ny + nz * nz);
  return [=](double x, double y, double z) {
    const double s = ((x - c) * nx + (y - c) * ny + (z - c + 0.29) * nz) / norm;
    return 20.0 - std::abs(s);
  };
}

// Prints the row docs/prep.md charts, and checks the bounds measured with 20 HU noise: the
// sub-voxel map within 0.065 h RMS and 0.2 h at worst (at 3 mm: 0.195 and 0.6 mm, inside the
// issue's goal of 0.25 and 0.6 mm), the mask's map at least 0.2 h RMS (its half-voxel
// staircase).
void check(const char* shape, double h, const Comparison& c) {
  std::printf(
      "%-6s %.0f mm  mask rms %.3f max %.3f | subvoxel rms %.3f max %.3f | projected rms %.3f "
      "max %.3f  (%zu voxels)\n",
      shape, h, c.mask.rms, c.mask.max, c.subvoxel.rms, c.subvoxel.max, c.projected.rms,
      c.projected.max, c.mask.count);
  EXPECT_GT(c.mask.count, 1000u);
  EXPECT_LE(c.subvoxel.rms, 0.065 * h) << shape << " " << h;
  EXPECT_LE(c.subvoxel.max, 0.2 * h) << shape << " " << h;
  EXPECT_LE(c.projected.rms, 0.065 * h) << shape << " " << h;  // d_surf as prep writes it
  EXPECT_LE(c.projected.max, 0.2 * h) << shape << " " << h;
  EXPECT_GE(c.mask.rms, 0.2 * h) << shape << " " << h;
}

TEST(SubvoxelDistance, SphereAccuracyByVoxelSize) {
  constexpr double kExtent = 80.0;
  for (double h : {1.0, 2.0, 3.0}) {
    const Comparison c = compare(sphere(kExtent), kExtent, h, 0.0);
    check("sphere", h, c);
  }
}

TEST(SubvoxelDistance, SlabAccuracyByVoxelSize) {
  constexpr double kExtent = 90.0;
  for (double h : {1.0, 2.0, 3.0}) {
    const Comparison c = compare(slab(kExtent), kExtent, h, 15.0);
    check("slab", h, c);
  }
}

// Only the components the mask keeps have a surface: a table the segmentation left out (same HU
// as tissue, three voxels from the patient) changes nothing, an arm it kept has its own surface.
TEST(SubvoxelDistance, OnlyTheMasksComponentsHaveASurface) {
  const Shape patient = [](double x, double y, double z) {
    return 12.0 -
           std::sqrt((x - 30.2) * (x - 30.2) + (y - 26.7) * (y - 26.7) + (z - 30.4) * (z - 30.4));
  };
  Phantom p = render(patient, 30, 2.0, 3u);
  Phantom air = p;
  // The table: a slab at j = 23..27 (y 46..54 mm), all i and k; left out of the mask.
  for (std::int64_t k = 0; k < 30; ++k)
    for (std::int64_t j = 23; j < 28; ++j)
      for (std::int64_t i = 0; i < 30; ++i) p.ct.at(i, j, k) = 0;
  DistanceMap with_table, without;
  subvoxel_signed_distance(surface_points(p.ct, p.mask, kIso), p.mask, 4.0, 60.0, with_table);
  subvoxel_signed_distance(surface_points(air.ct, air.mask, kIso), air.mask, 4.0, 60.0, without);
  EXPECT_EQ(with_table.data, without.data);
  // Inside the table the map is the distance to the patient, not to the table's faces.
  EXPECT_LT(with_table.at(15, 25, 15), -8.0f);

  // An arm the mask keeps: a second ball, disconnected, gets its own surface (D = 0 crossing).
  Phantom arm = air;
  for (std::int64_t k = 0; k < 30; ++k)
    for (std::int64_t j = 0; j < 30; ++j)
      for (std::int64_t i = 0; i < 30; ++i) {
        const double d = std::hypot(i - 24.0, j - 24.0, k - 15.0);
        if (d <= 3.0) arm.ct.at(i, j, k) = 0, arm.mask.at(i, j, k) = 1;
      }
  DistanceMap with_arm;
  subvoxel_signed_distance(surface_points(arm.ct, arm.mask, kIso), arm.mask, 4.0, 60.0, with_arm);
  EXPECT_GT(with_arm.at(24, 24, 15), 5.0f);   // the arm's centre: about 3.5 voxels = 7 mm deep
  EXPECT_LT(without.at(24, 24, 15), -15.0f);  // without it: far outside the patient
}

// Beyond the disc band the map is the exact distance to the points: a brute-force search over
// every point agrees to float rounding, on an anisotropic grid.
TEST(SubvoxelDistance, FarFieldIsTheExactDistanceToThePoints) {
  const Shape shape = [](double x, double y, double z) {
    const double dx = x - 20.3, dy = y - 18.9, dz = z - 21.7;
    return 11.0 - std::sqrt(dx * dx + 0.6 * dy * dy + dz * dz);
  };
  Phantom p = render(shape, 14, 3.0, 5u);
  // Stretch the grid: 3 x 2 x 3.5 mm.
  p.ct.grid.spacing = p.mask.grid.spacing = {3.0, 2.0, 3.5};
  const SurfacePoints points = surface_points(p.ct, p.mask, kIso);
  ASSERT_GT(points.points.size(), 100u);
  DistanceMap map;
  const double band = 1e-3;
  subvoxel_signed_distance(points, p.mask, band, 60.0, map);
  const Grid& g = map.grid;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        double best = 1e30;
        for (const SurfacePoint& q : points.points) {
          const double dx = static_cast<double>(i) * 3.0 - q.x,
                       dy = static_cast<double>(j) * 2.0 - q.y,
                       dz = static_cast<double>(k) * 3.5 - q.z;
          best = std::min(best, std::sqrt(dx * dx + dy * dy + dz * dz));
        }
        if (best <= band) continue;
        const double expected = p.mask.at(i, j, k) ? best : -best;
        ASSERT_NEAR(map.at(i, j, k), expected, 1.0 / 2048 + 1e-4 * (1.0 + best))
            << i << " " << j << " " << k;
      }
}

// The far field and the band run over slices in parallel (the points along k by their columns):
// the map is the same, bit for bit, for any thread count, on an anisotropic grid with several
// surfaces along each column.
TEST(SubvoxelDistance, MapIsBitIdenticalForAnyThreadCount) {
  const Shape shape = [](double x, double y, double z) {
    const double a = 9.0 - std::hypot(x - 14.2, y - 15.1, z - 12.7);
    const double b = 5.0 - std::hypot(x - 15.4, y - 14.3, z - 32.1);
    return std::max(a, b);
  };
  Phantom p = render(shape, 16, 2.5, 9u);
  p.ct.grid.spacing = p.mask.grid.spacing = {2.5, 2.0, 3.0};
  const SurfacePoints points = surface_points(p.ct, p.mask, kIso, 1);
  DistanceMap one, other;
  subvoxel_signed_distance(points, p.mask, 4.0, 60.0, one, 1);
  for (const unsigned threads : {2u, 3u, 7u}) {
    EXPECT_EQ(surface_points(p.ct, p.mask, kIso, threads).points.size(), points.points.size());
    subvoxel_signed_distance(points, p.mask, 4.0, 60.0, other, threads);
    ASSERT_EQ(other.data.size(), one.data.size());
    EXPECT_EQ(0, std::memcmp(other.data.data(), one.data.data(), one.data.size() * sizeof(float)))
        << threads << " threads";
  }
}

// Every edge whose two ends the mask puts on different sides carries one point, in the order
// of k, j, i and axis, wherever the edge lies in the row (the scan skips unchanging runs of
// voxels eight at a time): against a plain enumeration on a random mask with rows of 37.
TEST(SubvoxelDistance, SurfacePointsSitOnEveryEdgeTheMaskChangesAcross) {
  Grid grid;
  grid.dims = {37, 13, 11};
  grid.spacing = {1.0, 1.0, 1.0};
  CtVolume ct(grid, -1000);
  Mask mask(grid, 0);
  std::mt19937 rng(5u);
  for (std::size_t v = 0; v < mask.data.size(); ++v) {
    // Long runs with sparse changes, values 0, 1 and (as any nonzero) 2.
    mask.data[v] = (v / 23) % 3 == 0 ? 0 : static_cast<std::uint8_t>(1 + (rng() % 97 == 0));
    if (rng() % 41 == 0) mask.data[v] = 0;
    ct.data[v] = mask.data[v] ? 40 : -1000;
  }
  std::vector<std::array<std::int32_t, 4>> expected;
  for (std::int64_t k = 0; k < grid.dims[2]; ++k)
    for (std::int64_t j = 0; j < grid.dims[1]; ++j)
      for (std::int64_t i = 0; i < grid.dims[0]; ++i) {
        const bool in = mask.at(i, j, k) != 0;
        const std::int64_t next[3][3] = {{i + 1, j, k}, {i, j + 1, k}, {i, j, k + 1}};
        for (int a = 0; a < 3; ++a) {
          if (next[a][a] >= grid.dims[a]) continue;
          if ((mask.at(next[a][0], next[a][1], next[a][2]) != 0) != in)
            expected.push_back({static_cast<std::int32_t>(i), static_cast<std::int32_t>(j),
                                static_cast<std::int32_t>(k), a});
        }
      }
  ASSERT_GT(expected.size(), 500u);
  for (const unsigned threads : {1u, 3u}) {
    const SurfacePoints points = surface_points(ct, mask, kIso, threads);
    ASSERT_EQ(points.points.size(), expected.size()) << threads;
    for (std::size_t p = 0; p < expected.size(); ++p) {
      const SurfacePoint& got = points.points[p];
      ASSERT_EQ((std::array<std::int32_t, 4>{got.i, got.j, got.k, got.axis}), expected[p]) << p;
    }
  }
}

}  // namespace
}  // namespace palp
