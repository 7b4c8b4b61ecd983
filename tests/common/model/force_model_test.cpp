// The multiproxy force model (spec "Force model per contact point", steps 1-13) on tiny analytic
// scenes built inline: a flat skin face (D_surf = 20.25 - z, body below, outward normal +z) and
// bone slabs. Exact numbers where the law gives them, analytic bounds where it does not, the
// numerical guards, and zero heap allocation per tick (a counting global operator new below).
#include "model/force_model.hpp"

#include <gtest/gtest.h>

#include "support/heap_allocation_counter.hpp"
#include "support/linear_map.hpp"

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>
#include <new>
#include <numbers>
#include <random>
#include <string>

#include "base/errors.hpp"
#include "prep/maps/distance_transform.hpp"

namespace palp {
namespace {

constexpr double kZ0 = 20.25;             // the skin plane
constexpr double kCx = 50.0, kCy = 20.0;  // where the tool presses by default
const Index3 kDims{101, 41, 41};          // 0..100 x 0..40 x 0..40 mm at 1 mm
const Vec3d kUp{0.0, 0.0, 1.0};

constexpr GradientScheme kSchemes[] = {GradientScheme::AnalyticTrilinear,
                                       GradientScheme::CentralDifference,
                                       GradientScheme::PrecomputedField};
constexpr Storage kStorages[] = {Storage::Float32, Storage::Int16, Storage::Interleaved};

// D(p) = a . p + b at every voxel centre.
DistanceMap linear_map(Vec3d a, double b, Index3 dims = kDims) {
  return test::linear_map(dims, a, b);
}

DistanceMap flat_skin() {
  return linear_map({0, 0, -1}, kZ0);
}

std::shared_ptr<const FieldSampler> skin_only(SamplerConfig cfg = {}) {
  return std::make_shared<const FieldSampler>(flat_skin(), cfg);
}

std::shared_ptr<const FieldSampler> skin_and_bone(Vec3d bone_a, double bone_b,
                                                  SamplerConfig cfg = {}) {
  return std::make_shared<const FieldSampler>(flat_skin(), linear_map(bone_a, bone_b), cfg);
}

// Identity orientation, the pad (z = -8 in the tool frame) `depth` mm below the skin.
Pose press(double depth, double x = kCx, double y = kCy) {
  return Pose{{x, y, kZ0 + 8.0 - depth}, Quat{}};
}

void expect_vec_near(const Vec3d& a, const Vec3d& b, double tol, const std::string& what = "") {
  EXPECT_NEAR(a.x, b.x, tol) << what;
  EXPECT_NEAR(a.y, b.y, tol) << what;
  EXPECT_NEAR(a.z, b.z, tol) << what;
}

void expect_all_finite(const State& st) {
  EXPECT_TRUE(is_finite(st.f_device));
  EXPECT_TRUE(is_finite(st.tau_device));
  EXPECT_TRUE(is_finite(st.u));
  for (std::size_t i = 0; i < st.x.size(); ++i) {
    EXPECT_TRUE(is_finite(st.x[i]) && is_finite(st.s[i]) && is_finite(st.s_prev[i]) &&
                is_finite(st.p[i]) && is_finite(st.f[i]) && is_finite(st.f_friction[i]) &&
                std::isfinite(st.depth[i]));
  }
}

// alpha(z) of step 8 and the breakaway distance z* where alpha(z*) z* = 1 (bisection).
double alpha_of(double z, double z_max) {
  const double zs = z_max - 1.0;
  return z > 0.0 ? (1.0 / z_max) * std::pow(z, 8) / (std::pow(zs, 8) + std::pow(z, 8)) : 0.0;
}
double breakaway(double z_max) {
  double lo = z_max, hi = 10.0 * z_max + 10.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (alpha_of(mid, z_max) * mid > 1.0 ? hi : lo) = mid;
  }
  return hi;
}

TEST(ForceLaws, SurfaceForce) {
  EXPECT_EQ(surface_force(0.0), 0.0);
  EXPECT_EQ(surface_force(-3.0), 0.0);
  EXPECT_NEAR(surface_force(1.0), 1.78e-2 + 3.82e-3 + 2.28e-4, 1e-15);
  EXPECT_NEAR(surface_force(10.0), 17.8 + 0.382 + 0.00228, 1e-12);
  EXPECT_NEAR(surface_force(4.0), 1.78e-2 * 64 + 3.82e-3 * 16 + 2.28e-4 * 4, 1e-14);
  // The spec's note: the law gives 20 N at about 10.3 mm.
  EXPECT_NEAR(surface_force(10.32), 20.0, 0.05);
}

TEST(ForceLaws, BoneForce) {
  EXPECT_DOUBLE_EQ(bone_force(5.0, 40.0), 20.0);
  EXPECT_DOUBLE_EQ(bone_force(10.0, 40.0), 2.5);
  EXPECT_DOUBLE_EQ(bone_force(6.0, 40.0), 2500.0 / 216.0);
  EXPECT_EQ(bone_force(0.0, 40.0), 0.0);
  EXPECT_EQ(bone_force(-2.0, 40.0), 0.0);
  EXPECT_EQ(bone_force(std::nan(""), 40.0), 0.0);
  EXPECT_EQ(bone_force(1.0, 40.0), 40.0);     // 2500 N uncapped
  EXPECT_EQ(bone_force(1e-300, 40.0), 40.0);  // x^3 underflows: still the cap, no NaN
  EXPECT_EQ(bone_force(1.0, 25.0), 25.0);
  EXPECT_NEAR(5.0 * std::cbrt(0.5), 3.9685, 1e-4);  // where the default cap starts
  EXPECT_NEAR(bone_force(3.97, 40.0), 39.96, 0.01);
}

TEST(ForceLaws, SlopesAreTheDerivatives) {
  for (double x : {0.1, 1.0, 4.0, 10.0, 30.0}) {
    const double h = 1e-6;
    EXPECT_NEAR(surface_force_slope(x), (surface_force(x + h) - surface_force(x - h)) / (2 * h),
                1e-6 * (1 + x * x))
        << x;
  }
  EXPECT_EQ(surface_force_slope(0.0), 0.0);
  EXPECT_DOUBLE_EQ(surface_force_slope(10.0), 3 * 1.78e-2 * 100 + 2 * 3.82e-3 * 10 + 2.28e-4);
  EXPECT_DOUBLE_EQ(bone_force_slope(10.0, 40.0), 7500.0 / 1e4);  // |d/dx 2500 / x^3|
  EXPECT_EQ(bone_force_slope(3.0, 40.0), 0.0);                   // capped: flat
  EXPECT_EQ(bone_force_slope(0.0, 40.0), 0.0);
  EXPECT_EQ(bone_force_slope(-1.0, 40.0), 0.0);
}

TEST(ForceModel, StiffnessIsTheMeanSlopeOfThePointsInContact) {
  // Flat skin, no bone: every point at the same depth has slope f_s'(d) plus the friction
  // spring k; out of contact, 0.
  const Model model(skin_only(), parse_tool("finger:7"));
  State st = make_state(model);
  tick(model, st, press(4.0));
  EXPECT_NEAR(st.stiffness, surface_force_slope(4.0) + model.params().k, 1e-9);
  tick(model, st, press(-1.0));
  EXPECT_EQ(st.stiffness, 0.0);
}

TEST(ForceModel, FlatFaceGivesSurfaceLawAlongNormalForEveryN) {
  for (Storage storage : kStorages)
    for (GradientScheme scheme : kSchemes) {
      const auto fields = skin_only({scheme, storage});
      // Int16 rounds the map to its quantum (60/32767 mm here); the others are exact.
      const double tol = storage == Storage::Int16 ? 2e-3 : 1e-9;
      for (int n : {1, 7, 19, 37}) {
        const Model model(fields, parse_tool("finger:" + std::to_string(n)));
        for (double depth : {0.5, 2.0, 5.0, 9.0}) {
          State st = make_state(model);
          tick(model, st, press(depth));
          const std::string what = std::string(to_string(storage)) + "/" + to_string(scheme) +
                                   " N=" + std::to_string(n) + " depth " + std::to_string(depth);
          EXPECT_EQ(st.n_contact, n) << what;
          EXPECT_EQ(st.status, kTickOk) << what;
          expect_vec_near(st.f_device, surface_force(depth) * kUp, tol * (1 + depth * depth), what);
          expect_vec_near(st.tau_device, Vec3d{}, 1e-9 + tol * 100, what);
          // u = mean (p - x) = s - x = depth * v_s on entry (p = s).
          expect_vec_near(st.u, depth * kUp, tol, what);
          for (std::size_t i = 0; i < st.x.size(); ++i) {
            EXPECT_TRUE(st.in_contact[i]);
            EXPECT_NEAR(st.s[i].z, kZ0, tol);
            EXPECT_EQ(st.p[i], st.s[i]);
            EXPECT_EQ(st.s_prev[i], st.s[i]);
            EXPECT_NEAR(st.depth[i], depth, tol);
          }
        }
      }
    }
}

TEST(ForceModel, TiltedFaceAndRotatedTool) {
  // Skin plane with outward normal n = (0.6, 0, 0.8) through q0; the finger's axis turned onto n.
  const Vec3d n{0.6, 0.0, 0.8};
  const Vec3d q0{50.0, 20.0, 20.0};
  const auto fields =
      std::make_shared<const FieldSampler>(linear_map(-1.0 * n, dot(n, q0)), SamplerConfig{});
  const Model model(fields, parse_tool("finger:19"));
  const Quat q = axis_angle({0.0, 1.0, 0.0}, std::acos(0.8));  // z -> n
  expect_vec_near(rotate(q, kUp), n, 1e-12);
  const double depth = 3.0;
  State st = make_state(model);
  tick(model, st, Pose{q0 + (8.0 - depth) * n, q});
  EXPECT_EQ(st.n_contact, 19);
  expect_vec_near(st.f_device, surface_force(depth) * n, 1e-5);
  expect_vec_near(st.tau_device, Vec3d{}, 1e-4);
  for (std::size_t i = 0; i < st.s.size(); ++i) EXPECT_NEAR(dot(n, st.s[i] - q0), 0.0, 1e-5);
}

TEST(ForceModel, ContactNeedsPositiveDepth) {
  const Model model(skin_only(), parse_tool("finger:7"));
  State st = make_state(model);
  for (double depth : {0.0, -0.5, -30.0}) {
    tick(model, st, press(depth));
    EXPECT_EQ(st.n_contact, 0);
    EXPECT_EQ(st.f_device, Vec3d{});
    EXPECT_EQ(st.tau_device, Vec3d{});
    EXPECT_EQ(st.u, Vec3d{});
    for (std::size_t i = 0; i < st.x.size(); ++i) {
      EXPECT_FALSE(st.in_contact[i]);
      EXPECT_EQ(st.f[i], Vec3d{});
      EXPECT_EQ(st.p[i], st.x[i]);
    }
  }
}

// Drags a pressing tool along +x in steps of `step` mm for `ticks` ticks, calling f(state) after
// each tick.
template <class F>
void drag(const Model& model, State& st, double depth, double x0, double step, int ticks, F f) {
  for (int t = 0; t < ticks; ++t) {
    tick(model, st, press(depth, x0 + step * t));
    f(st);
  }
}

TEST(ForceModel, FrictionSticksBelowBreakawayAndSlipsBeyond) {
  const Model model(skin_only(), parse_tool("finger:1"));
  const ForceParams& prm = model.params();
  const double depth = 4.0;
  const double z_max = prm.c * surface_force(depth) + 1.0;
  const double z_stick = z_max - 1.0;
  const double z_star = breakaway(z_max);
  ASSERT_GT(z_star, z_max);

  // Stick: drag slowly by half of z_stick. The proxy moves by the integral of alpha(z) z over
  // the path, at most L * alpha(L) * L.
  State st = make_state(model);
  const double step = 0.001;
  tick(model, st, press(depth, 10.0));
  const Vec3d p0 = st.p[0];
  const int stick_ticks = static_cast<int>(0.5 * z_stick / step);
  drag(model, st, depth, 10.0, step, stick_ticks + 1, [](const State&) {});
  const double L = step * stick_ticks;
  EXPECT_LE(norm(st.p[0] - p0), L * alpha_of(L, z_max) * L + 1e-12);
  EXPECT_LT(norm(st.p[0] - p0), 0.01 * L);
  EXPECT_NEAR(st.f_friction[0].x, -prm.k * L, 0.01 * prm.k * L);  // opposes the motion
  EXPECT_NEAR(st.f_device.x, st.f_friction[0].x, 1e-12);
  EXPECT_NEAR(st.f_device.z, surface_force(depth), 1e-9);

  // Sliding on: |p - s| rises toward the breakaway distance z* and never passes it, so the
  // friction saturates at k z*; the proxy trails straight behind.
  double max_dist = 0.0;
  drag(model, st, depth, 10.0 + L, step, static_cast<int>(4.0 * z_star / step),
       [&](const State& s) {
         const double dist = norm(s.p[0] - s.s[0]);
         EXPECT_LE(dist, z_star + 1e-9);
         max_dist = std::max(max_dist, dist);
         EXPECT_LT(s.f_friction[0].x, 0.0);
         EXPECT_NEAR(s.p[0].y, s.s[0].y, 1e-12);
       });
  EXPECT_GT(max_dist, z_star - 0.01);

  // A jump beyond z* in one tick breaks away: the proxy lands exactly z_max behind s.
  for (double jump : {1.05 * z_star, 2.0 * z_star, 30.0}) {
    State sj = make_state(model);
    tick(model, sj, press(depth, 10.0));
    tick(model, sj, press(depth, 10.0 + jump));
    EXPECT_NEAR(norm(sj.p[0] - sj.s[0]), z_max, 1e-9) << jump;
    expect_vec_near(sj.f_friction[0], -prm.k * z_max * Vec3d{1, 0, 0}, 1e-9);
  }
  // A jump short of z* follows step 9's stick branch: p moves by |ds| alpha(|d|) d.
  for (double jump : {0.3 * z_stick, 0.9 * z_star}) {
    State sj = make_state(model);
    tick(model, sj, press(depth, 10.0));
    const double px = sj.p[0].x;
    tick(model, sj, press(depth, 10.0 + jump));
    EXPECT_NEAR(sj.p[0].x - px, jump * alpha_of(jump, z_max) * jump, 1e-9) << jump;
    EXPECT_LT(alpha_of(jump, z_max) * jump, 1.0);
  }
}

TEST(ForceModel, FrictionGrowsWithPressingForce) {
  const Model model(skin_only(), parse_tool("finger:7"));
  const ForceParams& prm = model.params();
  double last = 0.0;
  for (double depth : {1.0, 2.0, 4.0, 6.0}) {
    const double z_max = prm.c * surface_force(depth) + 1.0;
    const double z_star = breakaway(z_max);
    State st = make_state(model);
    double max_friction = 0.0;
    const double step = 0.005;
    // 60 mm of sliding: |p - s| approaches z* exponentially, over about z_max mm at light
    // pressure (z_stick ~ 0, alpha ~ 1/z_max) and about 5 mm at depth 6.
    drag(model, st, depth, 15.0, step, static_cast<int>(60.0 / step),
         [&](const State& s) { max_friction = std::max(max_friction, -s.f_device.x); });
    // Sliding friction saturates at k times the breakaway distance z* (>= z_max).
    EXPECT_LE(max_friction, prm.k * z_star + 1e-9) << depth;
    EXPECT_GE(max_friction, prm.k * (z_star - 0.02)) << depth;
    EXPECT_GT(max_friction, last) << depth;
    last = max_friction;
  }
}

TEST(ForceModel, FrictionIndependentOfNumberOfPoints) {
  const auto fields = skin_only();
  std::vector<Vec3d> reference;
  for (int n : {1, 7, 19, 37}) {
    const Model model(fields, parse_tool("finger:" + std::to_string(n)));
    State st = make_state(model);
    std::vector<Vec3d> forces;
    drag(model, st, 3.0, 15.0, 0.01, 3000, [&](const State& s) { forces.push_back(s.f_device); });
    if (reference.empty()) {
      reference = forces;
      continue;
    }
    for (std::size_t t = 0; t < forces.size(); ++t)
      ASSERT_NEAR(norm(forces[t] - reference[t]), 0.0, 1e-9) << "N=" << n << " tick " << t;
  }
}

TEST(ForceModel, NoCreepUnderJitterBelowBreakaway) {
  const Model model(skin_only(), parse_tool("finger:7"));
  const double depth = 6.0;
  State st = make_state(model);
  // Press, then push sideways by 1 mm (well below z_stick = c f_s(6) ~ 8 mm).
  drag(model, st, depth, 20.0, 0.001, 1001, [](const State&) {});
  const Vec3d p_ref = st.p[0];
  const Vec3d f_ref = st.f_device;
  ASSERT_NEAR(st.f_friction[0].x, -model.params().k * 1.0, 1e-3);
  // +-0.05 mm jitter around the offset position for 10000 ticks.
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> coin(0, 1);
  for (int t = 0; t < 10000; ++t) {
    const double jx = coin(rng) ? 0.05 : -0.05, jy = coin(rng) ? 0.05 : -0.05;
    tick(model, st, press(depth, 21.0 + jx, kCy + jy));
  }
  tick(model, st, press(depth, 21.0));
  EXPECT_LT(norm(st.p[0] - p_ref), 1e-4);
  EXPECT_LT(norm(st.f_device - f_ref), 1e-4);
  EXPECT_EQ(st.n_contact, 7);
}

TEST(ForceModel, ContactLostAndRegainedRestartsProxyAtSurfacePoint) {
  const Model model(skin_only(), parse_tool("finger:19"));
  State st = make_state(model);
  drag(model, st, 3.0, 20.0, 0.01, 500, [](const State&) {});
  ASSERT_GT(norm(st.p[0] - st.s[0]), 1.0);  // friction has built up
  // Lift off: nothing in contact, every proxy forgotten.
  tick(model, st, press(-2.0, 25.0));
  EXPECT_EQ(st.n_contact, 0);
  EXPECT_EQ(st.f_device, Vec3d{});
  for (std::size_t i = 0; i < st.x.size(); ++i) {
    EXPECT_FALSE(st.in_contact[i]);
    EXPECT_EQ(st.p[i], st.x[i]);
  }
  // Touch down elsewhere: the proxy starts at s, no friction on the entry tick.
  tick(model, st, press(2.0, 40.0));
  EXPECT_EQ(st.n_contact, 19);
  for (std::size_t i = 0; i < st.x.size(); ++i) {
    EXPECT_TRUE(st.in_contact[i]);
    EXPECT_EQ(st.p[i], st.s[i]);
    EXPECT_EQ(st.s_prev[i], st.s[i]);
    EXPECT_EQ(st.f_friction[i], Vec3d{});
  }
  expect_vec_near(st.f_device, surface_force(2.0) * kUp, 1e-9);
}

TEST(ForceModel, PointsOutsideTheGridHaveNoContact) {
  const Model model(skin_only(), parse_tool("finger:37"));
  State st = make_state(model);
  // Entirely beyond the grid: the plane's formula would say "inside", the spec says outside.
  tick(model, st, press(3.0, 200.0));
  EXPECT_EQ(st.n_contact, 0);
  EXPECT_TRUE(st.status & kTickOutsideGrid);
  EXPECT_EQ(st.f_device, Vec3d{});
  expect_all_finite(st);
  // Straddling the edge x = 100: the points beyond it (and in the outer half voxel) are out; the
  // mean over the rest is still f_s(depth) along the normal.
  tick(model, st, press(3.0, 97.0));
  int expected = 0;
  for (const Vec3d& p : model.tool().points) expected += (97.0 + p.x <= 100.0) ? 1 : 0;
  EXPECT_EQ(st.n_contact, expected);
  EXPECT_GT(expected, 0);
  EXPECT_LT(expected, 37);
  EXPECT_TRUE(st.status & kTickOutsideGrid);
  expect_vec_near(st.f_device, surface_force(3.0) * kUp, 1e-9);
  // Half a voxel past the last centre.
  const Model one(skin_only(), parse_tool("finger:1"));
  State s1 = make_state(one);
  tick(one, s1, press(3.0, 100.4));
  EXPECT_EQ(s1.n_contact, 0);
  tick(one, s1, press(3.0, 100.0));
  EXPECT_EQ(s1.n_contact, 1);
}

TEST(ForceModel, ZeroGradientGivesNoNaN) {
  // D_surf = 5 everywhere (inside, no direction); D_bone = -3 everywhere (near bone, no direction).
  for (GradientScheme scheme : kSchemes) {
    const auto fields = std::make_shared<const FieldSampler>(
        linear_map({0, 0, 0}, 5.0), linear_map({0, 0, 0}, -3.0), SamplerConfig{scheme});
    const Model model(fields, parse_tool("finger:7"));
    State st = make_state(model);
    for (int t = 0; t < 50; ++t) {
      tick(model, st, press(3.0, 30.0 + 0.2 * t));
      EXPECT_EQ(st.n_contact, 7);
      EXPECT_TRUE(st.status & kTickNoSkinDirection);
      EXPECT_EQ(st.f_device, Vec3d{});
      expect_all_finite(st);
    }
  }
}

TEST(ForceModel, BadPoseGivesZerosNotNaN) {
  const Model model(skin_only(), parse_tool("finger:7"));
  State st = make_state(model);
  tick(model, st, press(3.0));
  ASSERT_EQ(st.n_contact, 7);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const Pose& bad : {Pose{{nan, 20, 20}, Quat{}}, Pose{{50, 20, inf}, Quat{}},
                          Pose{{50, 20, 20}, Quat{0, 0, 0, 0}},
                          Pose{{50, 20, 20}, Quat{nan, 0, 0, 1}}, Pose{{1e12, 20, 20}, Quat{}}}) {
    tick(model, st, bad);
    EXPECT_EQ(st.n_contact, 0);
    EXPECT_TRUE(st.status & kTickBadPose);
    EXPECT_EQ(st.f_device, Vec3d{});
    expect_all_finite(st);
  }
  // A non-unit quaternion is normalised.
  tick(model, st, Pose{press(3.0).position, Quat{2.0, 0, 0, 0}});
  EXPECT_EQ(st.n_contact, 7);
  EXPECT_EQ(st.status, kTickOk);
  expect_vec_near(st.f_device, surface_force(3.0) * kUp, 1e-9);
}

TEST(ForceModel, BoneForceBelowTheCap) {
  // Bone below z = 10.25 (D_bone = 10.25 - z): at depth 4 the pad is 6 mm above it.
  const Model model(skin_and_bone({0, 0, -1}, 10.25), parse_tool("finger:7"));
  State st = make_state(model);
  tick(model, st, press(4.0));
  const double fb = 2500.0 / 216.0;
  expect_vec_near(st.f_device, (surface_force(4.0) + fb) * kUp, 1e-9);
  // z_max includes the bone force: a jump past breakaway leaves the proxy c f_n + 1 behind.
  const Model one(model.fields_ptr(), parse_tool("finger:1"));
  State s1 = make_state(one);
  const double z_max = one.params().c * (surface_force(4.0) + fb) + 1.0;
  tick(one, s1, press(4.0, 10.0));
  tick(one, s1, press(4.0, 10.0 + 1.1 * breakaway(z_max)));
  EXPECT_NEAR(norm(s1.p[0] - s1.s[0]), z_max, 1e-9);
}

TEST(ForceModel, BoneForceCappedAt40NAndConfigurable) {
  const auto fields = skin_and_bone({0, 0, -1}, 10.25);
  const Model model(fields, parse_tool("finger:7"));
  EXPECT_EQ(model.params().bone_fmax, 40.0);
  State st = make_state(model);
  tick(model, st, press(8.0));  // 2 mm above bone: 312.5 N uncapped
  expect_vec_near(st.f_device, (surface_force(8.0) + 40.0) * kUp, 1e-9);
  tick(model, st, press(9.9));  // 0.1 mm above bone: 2.5e6 N uncapped
  expect_vec_near(st.f_device, (surface_force(9.9) + 40.0) * kUp, 1e-9);
  tick(model, st, press(12.0));  // inside bone: f_b = 0 there
  expect_vec_near(st.f_device, surface_force(12.0) * kUp, 1e-9);

  ForceParams prm = model.params();
  set_param(prm, "bone_fmax", 25.0);
  const Model capped(fields, model.tool(), prm);
  State s2 = make_state(capped);
  tick(capped, s2, press(8.0));
  expect_vec_near(s2.f_device, (surface_force(8.0) + 25.0) * kUp, 1e-9);

  set_param(prm, "bone_enabled", 0.0);
  const Model off(fields, model.tool(), prm);
  State s3 = make_state(off);
  tick(off, s3, press(8.0));
  expect_vec_near(s3.f_device, surface_force(8.0) * kUp, 1e-9);
}

TEST(ForceModel, Eq4FlipsBoneForceThatWouldPullIntoTheBody) {
  // Past the bone: bone above the point (D_bone = z - 30.25), so v_b = -z, v_b . v_s = -1 and
  // d_bone = v_b - 4 v_s (v_b . v_s) = +3 z: the force still points out of the skin.
  const auto fields = skin_and_bone({0, 0, 1}, -30.25);
  const Model model(fields, parse_tool("finger:1"));
  State st = make_state(model);
  tick(model, st, press(4.0));  // the point is at z = 16.25, 14 mm below the bone
  const double fb = 2500.0 / (14.0 * 14.0 * 14.0);
  expect_vec_near(st.f_device, (surface_force(4.0) + fb) * kUp, 1e-9);

  // Oblique: v_b = (sin t, 0, -cos t) gives d_bone = (sin t, 0, 3 cos t).
  const double t = std::numbers::pi / 6.0;
  const Vec3d grad{-std::sin(t), 0.0, std::cos(t)};
  const Vec3d x{kCx, kCy, kZ0 - 4.0};
  const auto oblique = skin_and_bone(grad, -10.0 - dot(grad, x));  // D_bone(x) = -10
  const Model om(oblique, parse_tool("finger:1"));
  State so = make_state(om);
  tick(om, so, press(4.0));
  Vec3d dir{std::sin(t), 0.0, 3.0 * std::cos(t)};
  dir *= 1.0 / norm(dir);
  expect_vec_near(so.f_device - surface_force(4.0) * kUp, 2.5 * dir, 1e-4);

  // The factor is a parameter: with 1 the antiparallel case has no direction (d_bone = 0) and
  // the bone term is skipped, without NaN.
  ForceParams prm = model.params();
  set_param(prm, "bone_flip", 1.0);
  const Model flip1(fields, model.tool(), prm);
  State s1 = make_state(flip1);
  tick(flip1, s1, press(4.0));
  expect_vec_near(s1.f_device, surface_force(4.0) * kUp, 1e-12);
  expect_all_finite(s1);
}

TEST(ForceModel, BoneBelowSkinPushesOutWithoutFlip) {
  // v_b . v_s > 0: d_bone = v_b exactly, here tilted so the flip would have been visible.
  const double t = std::numbers::pi / 4.0;
  const Vec3d grad{-std::sin(t), 0.0, -std::cos(t)};  // v_b = (sin t, 0, cos t)
  const Vec3d x{kCx, kCy, kZ0 - 4.0};
  const Model model(skin_and_bone(grad, -10.0 - dot(grad, x)), parse_tool("finger:1"));
  State st = make_state(model);
  tick(model, st, press(4.0));
  expect_vec_near(st.f_device - surface_force(4.0) * kUp,
                  2.5 * Vec3d{std::sin(t), 0.0, std::cos(t)}, 1e-4);
}

TEST(ForceModel, TorqueIsLeverCrossForce) {
  // twofinger:1 tilted 20 degrees about y: only the +x pad touches the skin.
  const Model model(skin_only(), parse_tool("twofinger:1"));
  const double th = 20.0 * std::numbers::pi / 180.0;
  // Rotation about y: (x, z) -> (x cos + z sin, -x sin + z cos).
  const Vec3d lever{9.5 * std::cos(th) - 8.0 * std::sin(th), 0.0,
                    -9.5 * std::sin(th) - 8.0 * std::cos(th)};
  const Vec3d lever_left{-9.5 * std::cos(th) - 8.0 * std::sin(th), 0.0,
                         9.5 * std::sin(th) - 8.0 * std::cos(th)};
  const double depth = 2.0;
  const Vec3d device{kCx, kCy, kZ0 - depth - lever.z};
  ASSERT_GT(device.z + lever_left.z, kZ0);  // the other pad is above the skin
  State st = make_state(model);
  tick(model, st, Pose{device, axis_angle({0, 1, 0}, th)});
  ASSERT_EQ(st.n_contact, 1);
  EXPECT_TRUE(st.in_contact[1]);
  expect_vec_near(st.x[1], device + lever, 1e-12);
  const double F = surface_force(depth);
  expect_vec_near(st.f_device, F * kUp, 1e-9);
  expect_vec_near(st.tau_device, cross(lever, F * kUp), 1e-9);
  EXPECT_NEAR(st.tau_device.y, -lever.x * F, 1e-9);

  // Both pads level and pressing: the torques cancel in the mean.
  State both = make_state(model);
  tick(model, both, press(depth));
  EXPECT_EQ(both.n_contact, 2);
  expect_vec_near(both.tau_device, Vec3d{}, 1e-12);
}

TEST(ForceModel, ProbeUsesItsOwnParameters) {
  const Model model(skin_only(), parse_tool("probe:9x3"));
  EXPECT_EQ(model.params().c, 0.4);
  EXPECT_EQ(model.params().k, 0.3);
  State st = make_state(model);
  tick(model, st, Pose{{kCx, kCy, kZ0 + 50.0 - 2.0}, Quat{}});
  EXPECT_EQ(st.n_contact, 27);
  expect_vec_near(st.f_device, surface_force(2.0) * kUp, 1e-9);
}

TEST(ForceModel, AModelNeedsFieldsAndToolPoints) {
  Tool empty;
  EXPECT_THROW(Model(skin_only(), empty), UsageError);
  EXPECT_THROW(Model(nullptr, parse_tool("finger:1")), UsageError);
}

TEST(ForceModel, StateFromAnotherModelIsRefused) {
  const auto fields = skin_only();
  const Model a(fields, parse_tool("finger:7"));
  const Model b(fields, parse_tool("finger:19"));
  State st = make_state(a);
  tick(b, st, press(3.0));
  EXPECT_EQ(st.status, kTickBadState);
  EXPECT_EQ(st.n_contact, 0);
  EXPECT_EQ(st.f_device, Vec3d{});
  tick(a, st, press(3.0));
  EXPECT_EQ(st.n_contact, 7);
  reset(st);
  EXPECT_EQ(st.n_contact, 0);
  EXPECT_EQ(st.ticks, 0u);
  EXPECT_FALSE(st.in_contact[0]);
}

TEST(ForceModel, NoHeapAllocationPerTick) {
  // The counter does see allocations.
  g_allocations = 0;
  g_count_allocations = true;
  auto probe = std::make_unique<std::vector<int>>(16);
  g_count_allocations = false;
  EXPECT_GE(g_allocations.load(), 2);
  probe.reset();

  for (Storage storage : kStorages)
    for (GradientScheme scheme : kSchemes) {
      const Model model(skin_and_bone({0, 0, -1}, 10.25, {scheme, storage}),
                        parse_tool("finger:37"));
      State st = make_state(model);
      const double nan = std::numeric_limits<double>::quiet_NaN();
      g_allocations = 0;
      g_count_allocations = true;
      for (int t = 0; t < 3000; ++t) {
        // Approach, press, drag (stick and slip), lift, a bad pose, the grid edge.
        const double depth = t < 500 ? -5.0 + 0.02 * t : (t < 2500 ? 5.0 : -1.0);
        const double x = 20.0 + 0.03 * std::max(0, t - 500);
        Pose pose = press(depth, x);
        if (t == 2600) pose.position.x = nan;
        if (t > 2700) pose = press(3.0, 95.0 + 0.05 * (t - 2700));
        tick(model, st, pose);
      }
      g_count_allocations = false;
      EXPECT_EQ(g_allocations.load(), 0) << to_string(storage) << "/" << to_string(scheme);
      expect_all_finite(st);
    }
}

// ---------------------------------------------------------------------------------------------
// Bone modes: Printed (the default, eqs. 4-5 as printed) and Robust (a bone proxy per point).

// A plate of bone: voxel centres with z in [z_lo, z_hi] (whole voxels), infinite in x and y,
// optionally cut to x in [x_lo, x_hi]; its exact signed distance map on the test grid.
DistanceMap bone_plate(int z_lo, int z_hi, int x_lo = 0, int x_hi = 100) {
  Grid g;
  g.dims = kDims;
  Mask m(g, 0);
  for (std::int64_t k = z_lo; k <= z_hi; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = x_lo; i <= x_hi; ++i) m.at(i, j, k) = 1;
  return signed_distance(m);
}

ForceParams robust_params(double flip = 4.0) {
  ForceParams p = default_params(ToolKind::Finger);
  set_param(p, "bone_mode", 1.0);
  set_param(p, "bone_flip", flip);
  return p;
}

// Bone force of a single point pressed straight down to each depth in turn.
std::vector<double> bone_force_z_along(const Model& model, double from, double to, double step) {
  State st = make_state(model);
  std::vector<double> out;
  for (double d = from; d <= to + 1e-9; d += step) {
    tick(model, st, press(d));
    out.push_back(st.f_bone[0].z);
  }
  return out;
}

TEST(BoneMode, DefaultIsPrintedAndParametersValidate) {
  const ForceParams p = default_params(ToolKind::Finger);
  EXPECT_EQ(p.bone_mode, BoneMode::Printed);
  EXPECT_EQ(p.bone_k, 10.0);
  EXPECT_EQ(default_params(ToolKind::Probe).bone_mode, BoneMode::Printed);
  ForceParams q = p;
  set_param(q, "bone_mode", 1.0);
  EXPECT_EQ(q.bone_mode, BoneMode::Robust);
  set_param(q, "bone_k", 25.0);
  EXPECT_EQ(q.bone_k, 25.0);
  set_param(q, "bone_mode", 0.0);
  EXPECT_EQ(q.bone_mode, BoneMode::Printed);
  EXPECT_THROW(set_param(q, "bone_mode", 0.5), UsageError);
  EXPECT_THROW(set_param(q, "bone_k", -1.0), UsageError);
  EXPECT_EQ(parse_bone_mode("robust"), BoneMode::Robust);
  EXPECT_EQ(parse_bone_mode("printed"), BoneMode::Printed);
  EXPECT_THROW(parse_bone_mode("rigid"), UsageError);
  EXPECT_STREQ(to_string(BoneMode::Robust), "robust");
}

TEST(BoneMode, PrintedGivesNoForceInsideBoneRobustPushesBack) {
  // Thick bone below z = 10.25 (D_bone = 10.25 - z): the pad's point reaches it at depth 10.
  const auto fields = skin_and_bone({0, 0, -1}, 10.25);
  const Model printed(fields, parse_tool("finger:1"));
  State sp = make_state(printed);
  tick(printed, sp, press(12.0));  // 2 mm inside bone
  expect_vec_near(sp.f_bone[0], Vec3d{}, 1e-12);
  expect_vec_near(sp.f_device, surface_force(12.0) * kUp, 1e-9);
  EXPECT_TRUE(sp.status & kTickInsideBone);
  EXPECT_FALSE(sp.status & kTickBoneLatched);

  const Model robust(fields, parse_tool("finger:1"), robust_params());
  State sr = make_state(robust);
  for (double d = 4.0; d <= 12.0 + 1e-9; d += 0.1) tick(robust, sr, press(d));
  EXPECT_EQ(sr.bone_latch[0], kBoneLatched);
  EXPECT_TRUE(sr.status & kTickBoneLatched);
  EXPECT_TRUE(sr.status & kTickInsideBone);
  // pen = 2 mm past the surface: bone_fmax + bone_k pen, out along the bone normal.
  expect_vec_near(sr.f_bone[0], (40.0 + 10.0 * 2.0) * kUp, 1e-6);
  expect_vec_near(sr.f_device, (surface_force(12.0) + 60.0) * kUp, 1e-6);

  // Outside bone the two modes agree (the capped law), and the force is continuous at the
  // surface: 40 N just above it, 40 N plus a little just below.
  const std::vector<double> fr = bone_force_z_along(robust, 4.0, 10.05, 0.05);
  const std::vector<double> fp = bone_force_z_along(printed, 4.0, 10.05, 0.05);
  ASSERT_EQ(fr.size(), 122u);  // depths 4.00, 4.05, ..., 10.05
  for (std::size_t i = 0; i < 119; ++i) EXPECT_NEAR(fr[i], fp[i], 1e-9) << i;
  EXPECT_NEAR(fr[119], 40.0, 1e-6);                // 0.05 mm above the surface
  EXPECT_NEAR(fr[121], 40.0 + 10.0 * 0.05, 1e-6);  // 0.05 mm inside
}

TEST(BoneMode, RobustDoesNotTunnelThroughAThinRib) {
  // A 4-voxel plate (centres z = 10..13, surfaces at 9.5 and 13.5): its top is 6.75 mm under
  // the skin and its bottom 10.75 mm.
  const auto fields = std::make_shared<const FieldSampler>(flat_skin(), bone_plate(10, 13));
  const double top = kZ0 - 13.5;
  ForceParams flip0 = default_params(ToolKind::Finger);
  set_param(flip0, "bone_flip", 0.0);
  const Model printed(fields, parse_tool("finger:1"));
  const Model no_flip(fields, parse_tool("finger:1"), flip0);
  const Model robust(fields, parse_tool("finger:1"), robust_params());
  const double step = 0.05;
  const std::vector<double> fp = bone_force_z_along(printed, 2.0, 16.0, step);
  const std::vector<double> f0 = bone_force_z_along(no_flip, 2.0, 16.0, step);
  const std::vector<double> fr = bone_force_z_along(robust, 2.0, 16.0, step);
  int printed_zero = 0, no_flip_inward = 0;
  for (std::size_t i = 0; i < fp.size(); ++i) {
    const double d = 2.0 + step * static_cast<double>(i);
    if (d > top + 0.1 && d < top + 3.9) printed_zero += fp[i] == 0.0;  // inside: nothing
    if (d > top + 4.1) {
      EXPECT_GT(fp[i], 0.0) << d;      // eq. 4: below the rib still pushing out
      no_flip_inward += f0[i] < -1.0;  // without it: pulled further in
    }
    if (d > top + 0.01) {
      // Robust: the proxy stays on the top surface; the force grows with depth past it.
      EXPECT_NEAR(fr[i], 40.0 + 10.0 * (d - top), 1e-6) << d;
    }
  }
  EXPECT_GT(printed_zero, 70);
  EXPECT_GT(no_flip_inward, 20);
}

TEST(BoneMode, RobustCatchesAJumpAcrossTheRibInOneTick) {
  const auto fields = std::make_shared<const FieldSampler>(flat_skin(), bone_plate(10, 13));
  const double top = kZ0 - 13.5;
  const Model robust(fields, parse_tool("finger:1"), robust_params());
  State st = make_state(robust);
  tick(robust, st, press(5.0));  // above the rib: its surface is remembered
  EXPECT_EQ(st.bone_latch[0], kBoneAnchor);
  expect_vec_near(st.bone_anchor[0], Vec3d{kCx, kCy, 13.5}, 1e-9);
  tick(robust, st, press(13.0));  // 2.25 mm below the rib, never sampled inside it
  EXPECT_EQ(st.bone_latch[0], kBoneLatched);
  expect_vec_near(st.f_bone[0], (40.0 + 10.0 * (13.0 - top)) * kUp, 1e-6);
  EXPECT_FALSE(st.status & kTickInsideBone);

  // The printed law sees only the point below the rib: eq. 4 pushes it up at the cap, without
  // eq. 4 it is pulled down.
  const Model printed(fields, parse_tool("finger:1"));
  State sp = make_state(printed);
  tick(printed, sp, press(5.0));
  tick(printed, sp, press(13.0));
  expect_vec_near(sp.f_bone[0], 40.0 * kUp, 1e-6);
}

TEST(BoneMode, RobustLetsGoWhenLiftedSlidOffOrOutOfContact) {
  // Bone below z = 10.5 only for x in [40, 60] (a wide rib).
  Grid g;
  g.dims = kDims;
  Mask m(g, 0);
  for (std::int64_t k = 0; k <= 10; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = 40; i <= 60; ++i) m.at(i, j, k) = 1;
  const auto fields = std::make_shared<const FieldSampler>(flat_skin(), signed_distance(m));
  const Model robust(fields, parse_tool("finger:1"), robust_params());
  const Model printed(fields, parse_tool("finger:1"));

  // Press 1.5 mm into the bone, then lift: back above the surface the printed law returns.
  State st = make_state(robust);
  for (double d = 5.0; d <= 11.25 + 1e-9; d += 0.25) tick(robust, st, press(d));
  EXPECT_EQ(st.bone_latch[0], kBoneLatched);
  EXPECT_NEAR(st.f_bone[0].z, 40.0 + 10.0 * 1.5, 1e-6);
  tick(robust, st, press(9.0));
  EXPECT_NE(st.bone_latch[0], kBoneLatched);
  State sp = make_state(printed);
  tick(printed, sp, press(9.0));
  expect_vec_near(st.f_bone[0], sp.f_bone[0], 1e-9);

  // Press in again, then slide sideways off the rib at that depth: once no bone lies between
  // the point and the entry plane the proxy lets go and the printed law applies again.
  for (double d = 9.0; d <= 11.25 + 1e-9; d += 0.25) tick(robust, st, press(d));
  ASSERT_EQ(st.bone_latch[0], kBoneLatched);
  for (double x = kCx; x <= 66.0; x += 0.25) tick(robust, st, press(11.25, x));
  EXPECT_NE(st.bone_latch[0], kBoneLatched);
  State sp2 = make_state(printed);
  tick(printed, sp2, press(11.25, 66.0));
  expect_vec_near(st.f_bone[0], sp2.f_bone[0], 1e-9);

  // Latched again, then out of contact: everything is forgotten.
  for (double d = 9.0; d <= 11.25 + 1e-9; d += 0.25) tick(robust, st, press(d));
  ASSERT_EQ(st.bone_latch[0], kBoneLatched);
  tick(robust, st, press(-1.0));
  EXPECT_EQ(st.bone_latch[0], kBoneFree);
  EXPECT_EQ(st.n_contact, 0);
}

TEST(BoneMode, RobustEnteringContactInsideBonePushesOutOfTheSkin) {
  // No remembered surface: the proxy latches with n = v_s and pen = D_bone(x).
  const auto fields = skin_and_bone({0, 0, -1}, 10.25);
  const Model robust(fields, parse_tool("finger:1"), robust_params());
  State st = make_state(robust);
  tick(robust, st, press(11.5));  // first tick, 1.5 mm inside bone
  EXPECT_EQ(st.bone_latch[0], kBoneLatched);
  expect_vec_near(st.f_bone[0], (40.0 + 10.0 * 1.5) * kUp, 1e-6);
  tick(robust, st, press(12.5));  // 1 mm further: pen grows by 1 mm
  expect_vec_near(st.f_bone[0], (40.0 + 10.0 * 2.5) * kUp, 1e-6);
  expect_all_finite(st);
}

TEST(BoneMode, RobustFingerPadOverAThinRibAndNoHeapAllocation) {
  for (Storage storage : kStorages)
    for (GradientScheme scheme : kSchemes) {
      const auto fields = std::make_shared<const FieldSampler>(
          flat_skin(), bone_plate(10, 13, 45, 48), SamplerConfig{scheme, storage});
      const Model model(fields, parse_tool("finger:37"), robust_params());
      State st = make_state(model);
      g_allocations = 0;
      g_count_allocations = true;
      double min_fz = 1e300;
      for (int t = 0; t < 3000; ++t) {
        // Press hard over the rib, slide across it and back, jump, lift.
        const double depth = t < 500 ? 0.03 * t : (t < 2500 ? 15.0 : -1.0);
        const double x = 30.0 + 0.02 * std::max(0, t - 500);
        Pose pose = press(depth, x);
        if (t == 2400) pose = press(15.0, 80.0);
        tick(model, st, pose);
        if (st.n_contact > 0) min_fz = std::min(min_fz, st.f_device.z);
      }
      g_count_allocations = false;
      EXPECT_EQ(g_allocations.load(), 0) << to_string(storage) << "/" << to_string(scheme);
      EXPECT_GT(min_fz, 0.0);  // never pulled into the body
      expect_all_finite(st);
    }
}

}  // namespace
}  // namespace palp
