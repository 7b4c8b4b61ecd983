// Tests common/prep/maps/iso_projection.cpp: the sub-voxel map moved onto the trilinear HU's own
// iso-surface, checked against an independent brute force (the surface sampled densely by
// bisection along lines through every cell, the distance to the nearest sample).
#include "prep/maps/iso_projection.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "base/errors.hpp"
#include "prep/maps/subvoxel_distance.hpp"

namespace palp {
namespace {

constexpr double kIso = -500.0;

struct Scene {
  CtVolume ct;
  Mask mask;
};

// A ball of radius `radius` mm (centre off the lattice) on 3 mm voxels, HU a smooth ramp
// 1000 tanh((R - r) / 2 mm) - 500 around it, so the -500 HU iso-surface is near the sphere but
// the trilinear interpolant bends it between the nodes, as on a CT. Mask: HU >= -500.
Scene ball(double radius, std::int64_t n, double h) {
  Scene s;
  Grid grid;
  grid.dims = {n, n, n};
  grid.spacing = {h, h, h};
  s.ct = CtVolume(grid, 0, "ct");
  s.mask = Mask(grid, 0, "mask");
  const double c[3] = {0.5 * (n - 1) * h + 0.41, 0.5 * (n - 1) * h - 0.67,
                       0.5 * (n - 1) * h + 0.29};
  for (std::int64_t k = 0; k < n; ++k)
    for (std::int64_t j = 0; j < n; ++j)
      for (std::int64_t i = 0; i < n; ++i) {
        const double dx = i * h - c[0], dy = j * h - c[1], dz = k * h - c[2];
        const double r = std::sqrt(dx * dx + dy * dy + dz * dz);
        const auto hu =
            static_cast<std::int16_t>(std::lround(1000.0 * std::tanh((radius - r) / 2.0) - 500.0));
        s.ct.at(i, j, k) = hu;
        s.mask.at(i, j, k) = hu >= kIso ? 1 : 0;
      }
  return s;
}

double trilinear(const CtVolume& ct, const double x[3]) {
  const Grid& g = ct.grid;
  std::int64_t i0[3];
  double t[3];
  for (int a = 0; a < 3; ++a) {
    const double u = std::clamp(x[a] / g.spacing[a], 0.0, static_cast<double>(g.dims[a] - 1));
    i0[a] = std::min<std::int64_t>(static_cast<std::int64_t>(u), g.dims[a] - 2);
    t[a] = u - static_cast<double>(i0[a]);
  }
  double v = 0.0;
  for (int c = 0; c < 8; ++c) {
    const int b[3] = {c & 1, (c >> 1) & 1, c >> 2};
    double w = 1.0;
    for (int a = 0; a < 3; ++a) w *= b[a] ? t[a] : 1.0 - t[a];
    v += w * ct.at(i0[0] + b[0], i0[1] + b[1], i0[2] + b[2]);
  }
  return v;
}

// Points on the trilinear iso-surface: bisection along lines parallel to each axis, `lines` x
// `lines` of them through every cell.
std::vector<std::array<double, 3>> dense_surface(const CtVolume& ct, int lines) {
  std::vector<std::array<double, 3>> out;
  const Grid& g = ct.grid;
  const double h = g.spacing[0];
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    const double len = static_cast<double>(g.dims[axis] - 1) * h;
    const std::int64_t steps = (g.dims[u] - 1) * lines;
    for (std::int64_t a = 0; a <= steps; ++a)
      for (std::int64_t b = 0; b <= (g.dims[v] - 1) * lines; ++b) {
        double x[3];
        x[u] = static_cast<double>(a) * h / lines;
        x[v] = static_cast<double>(b) * h / lines;
        // march along the line a cell at a time, bisect each crossing
        for (std::int64_t cell = 0; cell + 1 < g.dims[axis]; ++cell) {
          double lo = static_cast<double>(cell) * h, hi = lo + h;
          x[axis] = lo;
          const double f_lo = trilinear(ct, x) - kIso;
          x[axis] = hi;
          const double f_hi = trilinear(ct, x) - kIso;
          if ((f_lo >= 0.0) == (f_hi >= 0.0)) continue;
          for (int it = 0; it < 40; ++it) {
            x[axis] = 0.5 * (lo + hi);
            ((trilinear(ct, x) - kIso >= 0.0) == (f_lo >= 0.0) ? lo : hi) = x[axis];
          }
          x[axis] = 0.5 * (lo + hi);
          out.push_back({x[0], x[1], x[2]});
        }
        (void)len;
      }
  }
  return out;
}

TEST(IsoProjection, NodesTakeTheDistanceToTheTrilinearIsoSurface) {
  constexpr double h = 3.0;
  const Scene s = ball(20.0, 20, h);
  const SurfacePoints points = surface_points(s.ct, s.mask, kIso);
  DistanceMap discs;
  subvoxel_signed_distance(points, s.mask, 2.0 * h, 60.0, discs);  // prep's band
  DistanceMap projected = discs;
  const IsoProjectionStats stats =
      project_onto_iso_surface(s.ct, s.mask, kIso, 3.0 * h, h, 0.25 * h, 60.0, projected);
  const auto surface = dense_surface(s.ct, 24);  // samples 0.125 mm apart
  ASSERT_GT(surface.size(), 10000u);
  // Nodes 1-9 mm inside: the sampled distance is at most ~0.125^2 / (2 * 1) mm above the true.
  double disc_max = 0.0, proj_max = 0.0, proj_sum2 = 0.0, disc_sum2 = 0.0;
  std::size_t nodes = 0, stalled = 0;
  const Grid& g = s.ct.grid;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const double d = projected.at(i, j, k);
        if (!(d >= 1.0 && d <= 3.0 * h - 0.5)) continue;
        const double q[3] = {i * h, j * h, k * h};
        double best2 = 1e30;
        for (const auto& p : surface) {
          const double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
          best2 = std::min(best2, dx * dx + dy * dy + dz * dz);
        }
        const double truth = std::sqrt(best2);
        const double e_proj = std::abs(d - truth), e_disc = std::abs(discs.at(i, j, k) - truth);
        proj_max = std::max(proj_max, e_proj);
        stalled += e_proj > 0.01;
        disc_max = std::max(disc_max, e_disc);
        proj_sum2 += e_proj * e_proj;
        disc_sum2 += e_disc * e_disc;
        ++nodes;
      }
  ASSERT_GT(nodes, 500u);
  const double proj_rms = std::sqrt(proj_sum2 / nodes), disc_rms = std::sqrt(disc_sum2 / nodes);
  std::printf(
      "ball R 20 mm, 3 mm voxels, %zu nodes 1-8.5 mm deep: discs rms %.3f max %.3f mm, "
      "projected rms %.4f max %.4f mm, %zu off by > 0.01 mm (%zu of %zu nodes within reach "
      "projected)\n",
      nodes, disc_rms, disc_max, proj_rms, proj_max, stalled, stats.projected, stats.visited);
  // Measured: rms 0.008, max 0.070 mm; 38 of 843 nodes, 5-8.5 mm deep, stop above the truth
  // by 0.01-0.07 mm where the descent stalls at a crease of the trilinear surface.
  EXPECT_LE(proj_rms, 0.015);
  EXPECT_LE(proj_max, 0.1);
  EXPECT_LE(stalled, nodes / 10);
  EXPECT_GE(disc_rms, 5.0 * proj_rms);  // the discs were off: the test can tell
  EXPECT_GE(stats.projected, stats.visited * 95 / 100);
}

// `v` stored in another order: new axis a is old axis `axis[a]`, reversed where `flip[a]`. The
// grid's direction and origin follow, so every voxel keeps its world position.
template <class T>
Volume<T> stored_otherwise(const Volume<T>& v, const std::array<int, 3>& axis,
                           const std::array<bool, 3>& flip) {
  const Grid& g = v.grid;
  Grid out;
  Index3 first{};
  for (int a = 0; a < 3; ++a) {
    out.dims[a] = g.dims[axis[a]];
    out.spacing[a] = g.spacing[axis[a]];
    first[axis[a]] = flip[a] ? g.dims[axis[a]] - 1 : 0;
    for (int r = 0; r < 3; ++r)
      out.world.direction[r * 3 + a] = (flip[a] ? -1.0 : 1.0) * g.world.direction[r * 3 + axis[a]];
  }
  for (int r = 0; r < 3; ++r) {
    out.world.origin[r] = g.world.origin[r];
    for (int c = 0; c < 3; ++c)
      out.world.origin[r] += g.world.direction[r * 3 + c] * g.spacing[c] * first[c];
  }
  Volume<T> o(out, T{});
  for (std::int64_t k = 0; k < out.dims[2]; ++k)
    for (std::int64_t j = 0; j < out.dims[1]; ++j)
      for (std::int64_t i = 0; i < out.dims[0]; ++i) {
        const std::int64_t n[3] = {i, j, k};
        Index3 old{};
        for (int a = 0; a < 3; ++a) old[axis[a]] = flip[a] ? g.dims[axis[a]] - 1 - n[a] : n[a];
        o.at(i, j, k) = v.at(old[0], old[1], old[2]);
      }
  return o;
}

// The same patient stored in another order (a NIfTI in RAS, a DICOM series in LPS) gets the same
// projected map bit for bit: the descent's floating-point path, and with it the point it settles
// on near a crease, must not depend on the storage order (before it did, the shared CT's d_surf
// differed by up to 0.37 mm at a few nodes between the two: shared_ct_dicom_test).
TEST(IsoProjection, TheStorageOrderDoesNotChangeTheMap) {
  constexpr double h = 3.0;
  Scene s = ball(80.0, 64, h);
  // Noise as on a CT (a fixed pseudo-random sequence) makes the surface lumpy, with creases.
  std::uint32_t state = 12345u;
  for (auto& hu : s.ct.data) {
    state = state * 1664525u + 1013904223u;
    hu = static_cast<std::int16_t>(hu + static_cast<int>(state >> 24) - 128);
  }
  for (std::size_t n = 0; n < s.mask.size(); ++n) s.mask.data[n] = s.ct.data[n] >= kIso ? 1 : 0;
  const SurfacePoints points = surface_points(s.ct, s.mask, kIso);
  DistanceMap discs;
  subvoxel_signed_distance(points, s.mask, 2.0 * h, 60.0, discs);
  DistanceMap projected = discs;
  const IsoProjectionStats stats =
      project_onto_iso_surface(s.ct, s.mask, kIso, 3.0 * h, h, 0.25 * h, 60.0, projected);
  EXPECT_GT(stats.projected, 1000u);
  const std::array<std::array<int, 3>, 3> orders = {{{0, 1, 2}, {2, 0, 1}, {1, 0, 2}}};
  const std::array<std::array<bool, 3>, 3> flips = {
      {{true, true, false}, {false, true, true}, {true, false, true}}};
  for (std::size_t o = 0; o < orders.size(); ++o) {
    SCOPED_TRACE(o);
    const std::array<int, 3>& axis = orders[o];
    DistanceMap other = stored_otherwise(discs, axis, flips[o]);
    project_onto_iso_surface(stored_otherwise(s.ct, axis, flips[o]),
                             stored_otherwise(s.mask, axis, flips[o]), kIso, 3.0 * h, h, 0.25 * h,
                             60.0, other);
    const DistanceMap expected = stored_otherwise(projected, axis, flips[o]);
    std::size_t differing = 0;
    float largest = 0.0f;
    for (std::size_t n = 0; n < other.size(); ++n) {
      differing += other.data[n] != expected.data[n];
      largest = std::max(largest, std::fabs(other.data[n] - expected.data[n]));
    }
    EXPECT_EQ(differing, 0u) << "largest difference " << largest << " mm";
  }
}

// The distance to a level set that is an exact plane (HU linear: trilinear reproduces it), from
// a start a few mm off the foot point.
TEST(IsoProjection, DistanceToAPlanarLevelSetIsExact) {
  Grid grid;
  grid.dims = {12, 12, 12};
  grid.spacing = {2.0, 2.0, 3.0};
  CtVolume ct(grid, 0, "ct");
  for (std::int64_t k = 0; k < 12; ++k)
    for (std::int64_t j = 0; j < 12; ++j)
      for (std::int64_t i = 0; i < 12; ++i)
        ct.at(i, j, k) = static_cast<std::int16_t>(37 * i + 23 * j - 61 * k);
  // HU = 18.5 x + 11.5 y - 20.333 z (per mm); level 100
  const double g[3] = {18.5, 11.5, -61.0 / 3.0};
  const double gn = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  const double q[3] = {11.0, 9.0, 13.0};
  const double hu_q = 18.5 * q[0] + 11.5 * q[1] - 61.0 / 3.0 * q[2];
  double start[3] = {q[0] + 2.0, q[1] - 3.0, q[2] + 1.0};
  const double d = distance_to_iso_surface(ct, 100.0, q, start);
  EXPECT_NEAR(d, std::abs(hu_q - 100.0) / gn, 2e-3);
  double flat_start[3] = {1.0, 1.0, 1.0};
  CtVolume flat(grid, 7, "ct");
  EXPECT_LT(distance_to_iso_surface(flat, 100.0, q, flat_start), 0.0);  // no level set
  Grid tiny;
  tiny.dims = {1, 4, 4};
  EXPECT_THROW(distance_to_iso_surface(CtVolume(tiny, 0, "ct"), 0.0, q, start), UsageError);
}

}  // namespace
}  // namespace palp
