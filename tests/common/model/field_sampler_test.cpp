// Distance-map sampling: trilinear values and the three gradient schemes are exact on linear
// fields, storages agree (int16 within its quantum), points outside the sampled box are
// outside, and bad inputs are refused.
#include "model/field_sampler.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "base/errors.hpp"

namespace palp {
namespace {

constexpr GradientScheme kSchemes[] = {GradientScheme::AnalyticTrilinear,
                                       GradientScheme::CentralDifference,
                                       GradientScheme::PrecomputedField};
constexpr Storage kStorages[] = {Storage::Float32, Storage::Int16, Storage::Interleaved};

// D(p) = a . p + b at every voxel centre p = (i sx, j sy, k sz).
DistanceMap linear_map(Index3 dims, Vec3 spacing, Vec3d a, double b) {
  Grid g;
  g.dims = dims;
  g.spacing = spacing;
  DistanceMap m(g, 0.0f);
  for (std::int64_t k = 0; k < dims[2]; ++k)
    for (std::int64_t j = 0; j < dims[1]; ++j)
      for (std::int64_t i = 0; i < dims[0]; ++i) {
        const Vec3d p{static_cast<double>(i) * spacing[0], static_cast<double>(j) * spacing[1],
                      static_cast<double>(k) * spacing[2]};
        m.at(i, j, k) = static_cast<float>(dot(a, p) + b);
      }
  return m;
}

// Signed distance to a sphere (positive inside).
DistanceMap sphere_map(Index3 dims, Vec3 spacing, Vec3d centre, double radius) {
  Grid g;
  g.dims = dims;
  g.spacing = spacing;
  DistanceMap m(g, 0.0f);
  for (std::int64_t k = 0; k < dims[2]; ++k)
    for (std::int64_t j = 0; j < dims[1]; ++j)
      for (std::int64_t i = 0; i < dims[0]; ++i) {
        const Vec3d p{static_cast<double>(i) * spacing[0], static_cast<double>(j) * spacing[1],
                      static_cast<double>(k) * spacing[2]};
        m.at(i, j, k) = static_cast<float>(radius - norm(p - centre));
      }
  return m;
}

// Dyadic coefficients so that every voxel value is exact in float.
const Vec3d kA{0.5, -0.25, 1.0};
const Vec3d kB{-0.75, 0.125, 0.5};
const Vec3 kSpacing{1.0, 0.5, 2.0};
const Index3 kDims{9, 12, 7};

TEST(FieldSampler, LinearFieldExactForEverySchemeAndStorage) {
  std::mt19937 rng(7);
  const Vec3d hi{8.0 * 1.0, 11.0 * 0.5, 6.0 * 2.0};
  std::uniform_real_distribution<double> ux(0.0, hi.x), uy(0.0, hi.y), uz(0.0, hi.z);
  for (Storage storage : kStorages)
    for (GradientScheme scheme : kSchemes) {
      const FieldSampler fs(linear_map(kDims, kSpacing, kA, 3.0),
                            linear_map(kDims, kSpacing, kB, -2.0), {scheme, storage});
      // Int16 rounds each voxel to its quantum; the interpolant is then off by at most half.
      const double tol_s = storage == Storage::Int16 ? fs.surf_quantum() * 0.5 + 1e-12 : 1e-12;
      const double tol_b = storage == Storage::Int16 ? fs.bone_quantum() * 0.5 + 1e-12 : 1e-12;
      for (int n = 0; n < 500; ++n) {
        // Include the corners of the box and exact voxel centres.
        Vec3d x{ux(rng), uy(rng), uz(rng)};
        if (n == 0) x = {0.0, 0.0, 0.0};
        if (n == 1) x = hi;
        if (n == 2) x = {4.0, 2.5, 6.0};
        const FieldSample s = fs.sample_surf(x);
        const FieldSample b = fs.sample_bone(x);
        ASSERT_TRUE(s.inside);
        ASSERT_TRUE(b.inside);
        EXPECT_NEAR(s.value, dot(kA, x) + 3.0, tol_s);
        EXPECT_NEAR(b.value, dot(kB, x) - 2.0, tol_b);
        // Gradient: exact with float storage; with int16, each voxel difference is off by at
        // most one quantum, so component a is off by at most quantum / spacing_a.
        const double gq = storage == Storage::Int16 && scheme != GradientScheme::PrecomputedField
                              ? 1.0 / 0.5
                              : 0.0;
        EXPECT_NEAR(s.grad.x, kA.x, 1e-12 + gq * fs.surf_quantum()) << to_string(scheme);
        EXPECT_NEAR(s.grad.y, kA.y, 1e-12 + gq * fs.surf_quantum()) << to_string(scheme);
        EXPECT_NEAR(s.grad.z, kA.z, 1e-12 + gq * fs.surf_quantum()) << to_string(scheme);
        EXPECT_NEAR(b.grad.x, kB.x, 1e-12 + gq * fs.bone_quantum()) << to_string(scheme);
        EXPECT_NEAR(b.grad.y, kB.y, 1e-12 + gq * fs.bone_quantum()) << to_string(scheme);
        EXPECT_NEAR(b.grad.z, kB.z, 1e-12 + gq * fs.bone_quantum()) << to_string(scheme);
      }
    }
}

TEST(FieldSampler, TrilinearMatchesHandInterpolationOnRandomData) {
  Grid g;
  g.dims = {4, 3, 5};
  g.spacing = {0.7, 1.3, 0.9};
  DistanceMap m(g, 0.0f);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> val(-10.0f, 10.0f);
  for (float& v : m.data) v = val(rng);
  const DistanceMap copy = m;
  const FieldSampler fs(m);
  std::uniform_real_distribution<double> t01(0.0, 1.0);
  for (int n = 0; n < 200; ++n) {
    const double u[3] = {t01(rng) * 3.0, t01(rng) * 2.0, t01(rng) * 4.0};
    const Vec3d x{u[0] * 0.7, u[1] * 1.3, u[2] * 0.9};
    std::int64_t i0[3];
    double t[3];
    for (int a = 0; a < 3; ++a) {
      i0[a] = std::min<std::int64_t>(static_cast<std::int64_t>(std::floor(u[a])), g.dims[a] - 2);
      t[a] = u[a] - static_cast<double>(i0[a]);
    }
    double expect = 0.0;
    for (int c = 0; c < 8; ++c) {
      const int bx = c & 1, by = (c >> 1) & 1, bz = (c >> 2) & 1;
      const double w = (bx ? t[0] : 1 - t[0]) * (by ? t[1] : 1 - t[1]) * (bz ? t[2] : 1 - t[2]);
      expect += w * copy.at(i0[0] + bx, i0[1] + by, i0[2] + bz);
    }
    const FieldSample s = fs.sample_surf(x);
    ASSERT_TRUE(s.inside);
    EXPECT_NEAR(s.value, expect, 1e-9);
  }
}

TEST(FieldSampler, AnalyticGradientIsTheDerivativeOfTheInterpolant) {
  Grid g;
  g.dims = {5, 6, 4};
  g.spacing = {1.0, 0.8, 1.5};
  DistanceMap m(g, 0.0f);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> val(-5.0f, 5.0f);
  for (float& v : m.data) v = val(rng);
  const FieldSampler fs(m);
  // Inside one cell the interpolant is smooth: compare with a fine finite difference.
  const Vec3d x{1.37, 2.11, 2.2};
  const FieldSample s = fs.sample_surf(x);
  const double h = 1e-6;
  const Vec3d e[3] = {{h, 0, 0}, {0, h, 0}, {0, 0, h}};
  const double fd[3] = {
      (fs.sample_surf(x + e[0]).value - fs.sample_surf(x - e[0]).value) / (2 * h),
      (fs.sample_surf(x + e[1]).value - fs.sample_surf(x - e[1]).value) / (2 * h),
      (fs.sample_surf(x + e[2]).value - fs.sample_surf(x - e[2]).value) / (2 * h)};
  EXPECT_NEAR(s.grad.x, fd[0], 1e-6);
  EXPECT_NEAR(s.grad.y, fd[1], 1e-6);
  EXPECT_NEAR(s.grad.z, fd[2], 1e-6);
}

TEST(FieldSampler, SchemesAgreeOnASmoothField) {
  const Index3 dims{41, 41, 41};
  const Vec3 spacing{1.0, 1.0, 1.0};
  const Vec3d centre{20.0, 20.0, 20.0};
  std::mt19937 rng(5);
  std::normal_distribution<double> dir(0.0, 1.0);
  std::uniform_real_distribution<double> rad(8.0, 16.0);
  for (Storage storage : kStorages)
    for (GradientScheme scheme : kSchemes) {
      const FieldSampler fs(sphere_map(dims, spacing, centre, 12.0), {scheme, storage});
      for (int n = 0; n < 200; ++n) {
        Vec3d v{dir(rng), dir(rng), dir(rng)};
        v *= 1.0 / norm(v);
        const double r = rad(rng);
        const FieldSample s = fs.sample_surf(centre + r * v);
        ASSERT_TRUE(s.inside);
        EXPECT_NEAR(s.value, 12.0 - r, 0.05);
        // The gradient of a sphere's distance is -v, of unit length (the trilinear interpolant's
        // own gradient is up to ~6% short of unit length at r = 8 voxels; its direction is good).
        EXPECT_NEAR(norm(s.grad), 1.0, 0.08) << to_string(scheme) << " " << to_string(storage);
        EXPECT_GT(dot(s.grad, -v) / norm(s.grad), 0.99)
            << to_string(scheme) << " " << to_string(storage);
      }
    }
}

TEST(FieldSampler, Int16WithinItsQuantisationBound) {
  const Index3 dims{30, 30, 30};
  const Vec3 spacing{1.0, 1.0, 1.0};
  const DistanceMap sphere = sphere_map(dims, spacing, {14.5, 15.2, 13.9}, 9.0);
  const FieldSampler f32(sphere);
  const FieldSampler i16(sphere, {GradientScheme::AnalyticTrilinear, Storage::Int16});
  // max |D| here is under 20 mm, so the quantum is under 1 um.
  const double q = i16.surf_quantum();
  EXPECT_GT(q, 0.0);
  EXPECT_LT(q, 1e-3);
  double max_abs = 0.0;
  for (float v : sphere.data) max_abs = std::max(max_abs, static_cast<double>(std::fabs(v)));
  EXPECT_DOUBLE_EQ(q, max_abs / 32767.0);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(0.0, 29.0);
  double worst = 0.0;
  for (int n = 0; n < 2000; ++n) {
    const Vec3d x{u(rng), u(rng), u(rng)};
    const FieldSample a = f32.sample_surf(x);
    const FieldSample b = i16.sample_surf(x);
    worst = std::max(worst, std::fabs(a.value - b.value));
    EXPECT_LE(std::fabs(a.value - b.value), 0.5 * q + 1e-9);
    EXPECT_LE(std::fabs(a.grad.x - b.grad.x), q + 1e-9);
    EXPECT_LE(std::fabs(a.grad.y - b.grad.y), q + 1e-9);
    EXPECT_LE(std::fabs(a.grad.z - b.grad.z), q + 1e-9);
  }
  EXPECT_GT(worst, 0.0);  // it really is quantised
  EXPECT_EQ(f32.surf_quantum(), 0.0);
}

TEST(FieldSampler, InterleavedMatchesFloat32Exactly) {
  const Index3 dims{20, 18, 16};
  const Vec3 spacing{1.0, 1.2, 0.8};
  for (GradientScheme scheme : kSchemes) {
    const DistanceMap s = sphere_map(dims, spacing, {9.0, 10.0, 6.0}, 7.0);
    const DistanceMap b = sphere_map(dims, spacing, {9.5, 9.0, 6.5}, 3.0);
    const FieldSampler a(s, b, {scheme, Storage::Float32});
    const FieldSampler il(s, b, {scheme, Storage::Interleaved});
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> ux(0.0, 19.0), uy(0.0, 17 * 1.2), uz(0.0, 15 * 0.8);
    for (int n = 0; n < 300; ++n) {
      const Vec3d x{ux(rng), uy(rng), uz(rng)};
      const FieldSample p = a.sample_surf(x), q = il.sample_surf(x);
      const FieldSample pb = a.sample_bone(x), qb = il.sample_bone(x);
      EXPECT_EQ(p.value, q.value);
      EXPECT_EQ(p.grad, q.grad);
      EXPECT_EQ(pb.value, qb.value);
      EXPECT_EQ(pb.grad, qb.grad);
    }
  }
}

TEST(FieldSampler, PairedSampleOfInterleavedRecordsEqualsEachMapsSample) {
  // The tick's one-pass sample of both maps (interleaved records with precomputed gradients)
  // gives what one sample of each map gives, bit for bit, inside and outside the box; other
  // layouts have no paired records and fall back to one sample of each.
  const Index3 dims{20, 18, 16};
  const Vec3 spacing{1.0, 1.2, 0.8};
  const DistanceMap s = sphere_map(dims, spacing, {9.0, 10.0, 6.0}, 7.0);
  const DistanceMap b = sphere_map(dims, spacing, {9.5, 9.0, 6.5}, 3.0);
  for (Storage storage : kStorages)
    for (GradientScheme scheme : kSchemes) {
      const FieldSampler fs(s, b, {scheme, storage});
      const bool paired =
          storage == Storage::Interleaved && scheme == GradientScheme::PrecomputedField;
      fs.dispatch([&](const auto& access) {
        EXPECT_EQ(access.pair_records != nullptr, paired)
            << to_string(storage) << " " << to_string(scheme);
        std::mt19937 rng(2);
        // a margin past the box on every side, so some points are outside
        std::uniform_real_distribution<double> ux(-1.0, 20.0), uy(-1.0, 17 * 1.2 + 1.0),
            uz(-1.0, 15 * 0.8 + 1.0);
        int outside = 0;
        for (int n = 0; n < 400; ++n) {
          const Vec3d x{ux(rng), uy(rng), uz(rng)};
          FieldSample ps, pb;
          access.surf_and_bone_at(x, ps, pb);
          const FieldSample qs = access.surf_at(x), qb = access.bone_at(x);
          EXPECT_EQ(ps.inside, qs.inside);
          EXPECT_EQ(pb.inside, qb.inside);
          EXPECT_EQ(ps.value, qs.value);
          EXPECT_EQ(ps.grad, qs.grad);
          EXPECT_EQ(pb.value, qb.value);
          EXPECT_EQ(pb.grad, qb.grad);
          outside += !qs.inside;
        }
        EXPECT_GT(outside, 0);
      });
    }
}

TEST(FieldSampler, OutsideTheSampledBoxIsOutside) {
  for (Storage storage : kStorages)
    for (GradientScheme scheme : kSchemes) {
      // Everything inside the body (D = 50 everywhere): only the box decides.
      const FieldSampler fs(linear_map({11, 11, 11}, {1.0, 1.0, 1.0}, {0, 0, 0}, 50.0),
                            {scheme, storage});
      const double nan = std::numeric_limits<double>::quiet_NaN();
      const double inf = std::numeric_limits<double>::infinity();
      for (const Vec3d& x : {Vec3d{-0.01, 5, 5}, Vec3d{5, -0.3, 5}, Vec3d{5, 5, -1e-9},
                             Vec3d{10.01, 5, 5},  // the outer half voxel past the last centre
                             Vec3d{5, 10.4, 5}, Vec3d{5, 5, 10.5}, Vec3d{1e30, 5, 5},
                             Vec3d{nan, 5, 5}, Vec3d{5, inf, 5}, Vec3d{5, 5, -inf}}) {
        const FieldSample s = fs.sample_surf(x);
        EXPECT_FALSE(s.inside) << x.x << " " << x.y << " " << x.z;
        EXPECT_EQ(s.value, kOutsideValue);
        EXPECT_EQ(s.grad, (Vec3d{0, 0, 0}));
      }
      // The box itself, edges included, is inside.
      for (const Vec3d& x : {Vec3d{0, 0, 0}, Vec3d{10, 10, 10}, Vec3d{10, 0, 5}}) {
        const FieldSample s = fs.sample_surf(x);
        EXPECT_TRUE(s.inside);
        EXPECT_NEAR(s.value, 50.0, 1e-9);
        EXPECT_NEAR(norm(s.grad), 0.0, 1e-12);
      }
    }
}

TEST(FieldSampler, SingleSliceAxis) {
  // One voxel along z: only z = 0 is sampled; the gradient along z is zero.
  for (GradientScheme scheme : kSchemes) {
    const FieldSampler fs(linear_map({6, 5, 1}, {1.0, 1.0, 1.0}, {1.0, 0.5, 0.0}, 0.0),
                          {scheme, Storage::Float32});
    const FieldSample s = fs.sample_surf({2.5, 1.5, 0.0});
    ASSERT_TRUE(s.inside);
    EXPECT_NEAR(s.value, 3.25, 1e-12);
    EXPECT_NEAR(s.grad.x, 1.0, 1e-12);
    EXPECT_NEAR(s.grad.y, 0.5, 1e-12);
    EXPECT_EQ(s.grad.z, 0.0);
    EXPECT_FALSE(fs.sample_surf({2.5, 1.5, 0.1}).inside);
  }
}

TEST(FieldSampler, NoBoneMap) {
  const FieldSampler fs(linear_map({5, 5, 5}, {1, 1, 1}, kA, 0.0));
  EXPECT_FALSE(fs.has_bone());
  EXPECT_FALSE(fs.sample_bone({1, 1, 1}).inside);
}

TEST(FieldSampler, RefusesMismatchedGridsAndNonFiniteValues) {
  EXPECT_THROW(FieldSampler(linear_map({5, 5, 5}, {1, 1, 1}, kA, 0.0),
                            linear_map({5, 5, 6}, {1, 1, 1}, kA, 0.0)),
               UsageError);
  EXPECT_THROW(FieldSampler(linear_map({5, 5, 5}, {1, 1, 1}, kA, 0.0),
                            linear_map({5, 5, 5}, {1, 1, 2}, kA, 0.0)),
               UsageError);
  DistanceMap bad = linear_map({5, 5, 5}, {1, 1, 1}, kA, 0.0);
  bad.at(2, 2, 2) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(FieldSampler{bad}, InputError);
  bad.at(2, 2, 2) = std::numeric_limits<float>::infinity();
  EXPECT_THROW(FieldSampler(linear_map({5, 5, 5}, {1, 1, 1}, kA, 0.0), bad), InputError);
}

TEST(FieldSampler, NamesAndFootprint) {
  for (GradientScheme s : kSchemes) EXPECT_EQ(parse_gradient_scheme(to_string(s)), s);
  for (Storage s : kStorages) EXPECT_EQ(parse_storage(to_string(s)), s);
  EXPECT_THROW(parse_gradient_scheme("sobel"), UsageError);
  EXPECT_THROW(parse_storage("float64"), UsageError);

  const DistanceMap m = linear_map({4, 4, 4}, {1, 1, 1}, kA, 0.0);
  EXPECT_EQ(
      FieldSampler(m, m, {GradientScheme::AnalyticTrilinear, Storage::Float32}).bytes_per_voxel(),
      8u);
  EXPECT_EQ(
      FieldSampler(m, m, {GradientScheme::AnalyticTrilinear, Storage::Int16}).bytes_per_voxel(),
      4u);
  EXPECT_EQ(FieldSampler(m, m, {GradientScheme::CentralDifference, Storage::Interleaved})
                .bytes_per_voxel(),
            8u);
  EXPECT_EQ(FieldSampler(m, m, {GradientScheme::PrecomputedField, Storage::Interleaved})
                .bytes_per_voxel(),
            32u);
  EXPECT_EQ(
      FieldSampler(m, m, {GradientScheme::PrecomputedField, Storage::Float32}).bytes_per_voxel(),
      32u);
}

}  // namespace
}  // namespace palp
