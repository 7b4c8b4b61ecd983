// The force model's tick stages one at a time (model/tick_stages.hpp) on tiny analytic scenes:
// a flat skin (D_surf = 20.25 - z, outward normal +z) and bone slabs. Expectations come from the
// spec's equations and the geometry, not from the stages: exact numbers where the equation gives
// them, bounds where it does not.
#include "model/tick_stages.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>

#include "model/tool.hpp"
#include "support/linear_map.hpp"

namespace palp {
namespace {

using namespace tick_stages;

constexpr double kZ0 = 20.25;  // the skin plane
const Index3 kDims{41, 41, 41};

// D(p) = a . p + b at every voxel centre (1 mm voxels).
DistanceMap linear_map(Vec3d a, double b) {
  return test::linear_map(kDims, a, b);
}

// Skin at z = 20.25; bone below z = top (D_bone = top - z: positive inside, normal +z).
FieldSampler skin_over_bone(double top) {
  return FieldSampler(linear_map({0, 0, -1}, kZ0), linear_map({0, 0, -1}, top));
}

// Calls f(access) with the sampler's FieldAccess.
template <class F>
void with_access(const FieldSampler& fields, F&& f) {
  fields.dispatch([&](const auto& access) { f(access); });
}

TEST(TickStages, BeginTickRefusesUnusablePosesAndPlacesPointsByTheRotation) {
  const ForceParams prm;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(begin_tick(prm, true, 0.5, Pose{{nan, 0, 0}, Quat{}}).status, kTickBadPose);
  EXPECT_EQ(begin_tick(prm, true, 0.5, Pose{{1e9, 0, 0}, Quat{}}).status, kTickBadPose);
  EXPECT_EQ(begin_tick(prm, true, 0.5, Pose{{0, 0, 0}, Quat{0, 0, 0, 0}}).status, kTickBadPose);
  const TickRun bad = begin_tick(prm, true, 0.5, Pose{{nan, 0, 0}, Quat{}});
  EXPECT_EQ(place_point(bad, {1, 2, 3}), Vec3d{});
  // 90 degrees about z, given unnormalised (|q| = 2): (1, 0, 0) -> (0, 1, 0).
  const double h = std::sqrt(0.5) * 2.0;
  const TickRun run = begin_tick(prm, true, 0.5, Pose{{10, 20, 30}, Quat{h, 0, 0, h}});
  ASSERT_EQ(run.status, kTickOk);
  const Vec3d x = place_point(run, {1, 0, 0});
  EXPECT_NEAR(x.x, 10.0, 1e-12);
  EXPECT_NEAR(x.y, 21.0, 1e-12);
  EXPECT_NEAR(x.z, 30.0, 1e-12);
  ForceParams no_bone;
  no_bone.bone_enabled = false;
  EXPECT_FALSE(begin_tick(no_bone, true, 0.5, Pose{}).bone_on);
  EXPECT_FALSE(begin_tick(prm, false, 0.5, Pose{}).bone_on);
}

TEST(TickStages, ContactIsDSurfPositiveAndTheNormalPointsOutOfTheSkin) {
  const FieldSampler fields = skin_over_bone(5.0);
  const ForceParams prm;
  with_access(fields, [&](const auto& a) {
    TickRun run = begin_tick(prm, true, 0.5, Pose{});
    State st = make_state(1);
    PointWork w;
    w.x = w.xc = {20, 20, kZ0 + 1.0};  // 1 mm above the skin
    sample_skin(a, run, w);
    EXPECT_FALSE(skin_contact(st, 0, w));
    EXPECT_EQ(st.p[0], w.x);  // dropped: s = p = x
    w.x = w.xc = {20, 20, kZ0 - 3.0};
    sample_skin(a, run, w);
    ASSERT_TRUE(skin_contact(st, 0, w));
    EXPECT_TRUE(w.entering);
    EXPECT_NEAR(w.skin.value, 3.0, 1e-6);
    skin_direction(prm, st, 0, false, w);
    EXPECT_TRUE(w.has_dir);
    EXPECT_NEAR(w.v_s.z, 1.0, 1e-9);
    // Off the grid: not in contact, and the tick says so.
    w.x = {-50, 20, 10};
    sample_skin(a, run, w);
    EXPECT_NE(run.status & kTickOutsideGrid, 0u);
  });
}

TEST(TickStages, WithoutAGradientOnlyThePalpDirectionKeepsTheLastNormal) {
  const ForceParams prm;
  State st = make_state(1);
  st.normal[0] = {0, 1, 0};
  PointWork w;
  w.skin.value = 3.0;  // no gradient
  w.entering = false;
  skin_direction(prm, st, 0, false, w);
  EXPECT_FALSE(w.has_dir);
  EXPECT_EQ(w.v_s, Vec3d{});
  skin_direction(prm, st, 0, true, w);
  EXPECT_TRUE(w.has_dir);
  EXPECT_EQ(w.v_s, (Vec3d{0, 1, 0}));
  w.entering = true;  // on entry there is no last normal
  skin_direction(prm, st, 0, true, w);
  EXPECT_FALSE(w.has_dir);
  TickRun run;
  flag_skin_direction(run, w);
  EXPECT_EQ(run.status, kTickNoSkinDirection);
}

TEST(TickStages, PrintedBoneLawIsEq4And5) {
  ForceParams prm;
  PointWork w;
  w.bone.value = -5.0;  // 5 mm outside bone: f_b = 20 N
  w.v_s = {0, 0, 1};
  w.v_b = {0, 0, 1};
  w.has_vb = true;
  bone_law_printed(prm, w);
  EXPECT_NEAR(w.f_struct.z, 20.0, 1e-12);
  // v_b pointing into the skin (v_b . v_s < 0) is flipped: d = v_b - 4 (v_b . v_s) v_s.
  w.v_b = {std::sqrt(0.5), 0, -std::sqrt(0.5)};
  bone_law_printed(prm, w);
  const Vec3d d{std::sqrt(0.5), 0, -std::sqrt(0.5) + 4.0 * std::sqrt(0.5)};
  EXPECT_NEAR(w.f_struct.x, 20.0 * d.x / norm(d), 1e-12);
  EXPECT_NEAR(w.f_struct.z, 20.0 * d.z / norm(d), 1e-12);
  w.bone.value = 1.0;  // inside bone: nothing
  bone_law_printed(prm, w);
  EXPECT_EQ(w.f_struct, Vec3d{});
}

// One point pressed to `depth` mm below the skin through the bone proxy's three steps.
struct ProxyStep {
  std::uint8_t latch;
  PointWork w;
};
template <class Access>
ProxyStep proxy_step(const Access& a, BoneProxyRule rule, State& st, double z, bool entering) {
  ForceParams prm;
  prm.bone_k = 10.0;
  TickRun run = begin_tick(prm, true, 0.5, Pose{});
  PointWork w;
  w.x = w.xc = {20, 20, z};
  w.entering = entering;
  sample_skin_and_bone(a, run, w);
  skin_direction(prm, st, 0, false, w);
  bone_direction(prm, w);
  std::uint8_t latch = bone_proxy_enter(a, run, rule, st, 0, w);
  latch = bone_proxy_hold(a, run, rule, st, 0, latch, w);
  if (w.latched) {
    st.bone_latch[0] = latch;
  } else {
    bone_proxy_remember(st, 0, w);
  }
  st.x[0] = w.xc;
  return {st.bone_latch[0], w};
}

TEST(TickStages, BoneProxyRemembersLatchesAndPushesBackWithItsSpring) {
  // Bone below z = 10.5 (a voxel boundary); the point descends from 12 to 9.5 mm.
  const FieldSampler fields = skin_over_bone(10.5);
  with_access(fields, [&](const auto& a) {
    for (const BoneProxyRule rule : {kPaperBoneProxy, kPalpBoneProxy}) {
      State st = make_state(1);
      const ProxyStep above = proxy_step(a, rule, st, 12.0, true);
      EXPECT_EQ(above.latch, kBoneAnchor);
      EXPECT_NEAR(st.bone_anchor[0].z, 10.5, 1e-6);  // the surface straight beneath
      const ProxyStep in = proxy_step(a, rule, st, 9.5, false);
      EXPECT_EQ(in.latch, kBoneLatched);
      // pen = 1 mm behind the plane: bone_fmax + bone_k * 1 = 50 N along +z
      EXPECT_NEAR(in.w.f_struct.z, 50.0, 1e-5);
      EXPECT_EQ(in.w.k_struct, 10.0);
      // the palp rule holds the contact point on the plane; the paper's leaves it at x
      EXPECT_NEAR(in.w.xc.z, rule.constrain_contact ? 10.5 : 9.5, 1e-5);
      const ProxyStep out = proxy_step(a, rule, st, 11.0, false);  // back above: let go
      EXPECT_EQ(out.latch, kBoneAnchor);
      EXPECT_FALSE(out.w.latched);
    }
  });
}

TEST(TickStages, BoneProxyCatchesAPathThroughAThinPlate) {
  // A 1 mm plate (voxel rows z = 10): a point jumping from above it to below it in one tick
  // latches on its top, as the path crossed bone.
  Grid g;
  g.dims = kDims;
  g.spacing = {1.0, 1.0, 1.0};
  DistanceMap plate(g, -5.0f);
  for (std::int64_t j = 0; j < kDims[1]; ++j)
    for (std::int64_t i = 0; i < kDims[0]; ++i) {
      for (std::int64_t k = 0; k < kDims[2]; ++k)
        plate.at(i, j, k) = static_cast<float>(0.5 - std::fabs(static_cast<double>(k) - 10.0));
    }
  const FieldSampler fields(linear_map({0, 0, -1}, kZ0), std::move(plate));
  with_access(fields, [&](const auto& a) {
    State st = make_state(1);
    EXPECT_EQ(proxy_step(a, kPalpBoneProxy, st, 12.0, true).latch, kBoneAnchor);
    const ProxyStep through = proxy_step(a, kPalpBoneProxy, st, 8.0, false);
    EXPECT_EQ(through.latch, kBoneLatched);
    EXPECT_GT(through.w.f_struct.z, 40.0);
  });
}

TEST(TickStages, TheRulesDifferOnlyWhereTheyAreDocumented) {
  // Entering contact already inside bone, with both directions known: the paper latches along
  // the skin normal, palp along the bone's. Bone below z = 10.5 tilted: D_bone = 10.5 - z + 0.5 x'.
  const FieldSampler fields(linear_map({0, 0, -1}, kZ0), linear_map({0.5, 0, -1}, 10.5 - 10.0));
  with_access(fields, [&](const auto& a) {
    State paper = make_state(1), palp = make_state(1);
    const ProxyStep pp = proxy_step(a, kPaperBoneProxy, paper, 9.0, true);
    const ProxyStep pl = proxy_step(a, kPalpBoneProxy, palp, 9.0, true);
    ASSERT_EQ(pp.latch, kBoneLatched);
    ASSERT_EQ(pl.latch, kBoneLatched);
    EXPECT_NEAR(paper.bone_normal[0].z, 1.0, 1e-9);  // v_s
    const double inv = 1.0 / std::sqrt(1.25);        // v_b = (-0.5, 0, 1) / |.|
    EXPECT_NEAR(palp.bone_normal[0].x, -0.5 * inv, 1e-6);
    EXPECT_NEAR(palp.bone_normal[0].z, inv, 1e-6);
  });
}

TEST(TickStages, SkinLawsAndSurfacePoint) {
  ForceParams prm;
  State st = make_state(1);
  PointWork w;
  w.skin.value = 10.0;
  w.v_s = {0, 0, 1};
  w.has_dir = true;
  w.xc = {1, 2, 3};
  w.entering = true;
  skin_force_printed(w);
  // f_s(10) = 17.8 + 0.382 + 0.00228 N
  EXPECT_NEAR(w.f_surf.z, 17.8 + 0.382 + 0.00228, 1e-12);
  EXPECT_NEAR(w.k_skin, 3 * 1.78e-2 * 100 + 2 * 3.82e-3 * 10 + 2.28e-4, 1e-12);
  skin_force_saturated(prm, st, 0, w);
  const double fs = 17.8 + 0.382 + 0.00228;
  EXPECT_NEAR(w.f_surf.z, fs / std::pow(1.0 + std::pow(fs / 30.0, 4), 0.25), 1e-12);
  EXPECT_EQ(st.normal[0], w.v_s);  // kept for past the band
  surface_point(st, 0, w);
  EXPECT_EQ(w.s, (Vec3d{1, 2, 13}));
  EXPECT_EQ(w.p_last, w.s);  // on entry the proxy starts on s
  w.entering = false;
  w.has_dir = false;
  st.s[0] = {5, 5, 5};
  surface_point(st, 0, w);
  EXPECT_EQ(w.s, (Vec3d{5, 5, 5}));  // no direction: held
}

TEST(TickStages, PaperFrictionBreaksAwayAtZMax) {
  ForceParams prm;  // c = 2 mm/N, k = 0.4 N/mm
  PointWork w;
  w.v_s = {0, 0, 1};
  w.f_surf = {0, 0, 2.0};  // z_max = 2 * 2 + 1 = 5 mm
  w.s = {10, 0, 0};
  w.s_last = {9.9, 0, 0};
  w.p_last = {0, 0, 0};  // 10 mm behind: past breakaway, slips to 5 mm behind s
  friction_paper(prm, w);
  EXPECT_NEAR(w.p.x, 5.0, 1e-12);
  EXPECT_NEAR(w.f_friction.x, -0.4 * 5.0, 1e-12);
  w.p_last = {9, 0, 0};  // 1 mm behind: alpha = 1 / (5 (1 + 4^8)), creeps by 0.1 alpha d
  friction_paper(prm, w);
  const double alpha = 1.0 / (5.0 * (1.0 + std::pow(4.0, 8)));
  EXPECT_NEAR(w.p.x, 9.0 + 0.1 * alpha * 1.0, 1e-12);
}

TEST(TickStages, CoulombFrictionIsBoundedByMuFn) {
  ForceParams prm;
  prm.mu = 0.5;
  PointWork w;
  w.v_s = {0, 0, 1};
  w.f_surf = {0, 0, 4.0};  // radius mu f_n / k = 5 mm
  w.s = {10, 0, 3};
  w.p_last = {0, 0, 0};
  friction_coulomb(prm, w);
  EXPECT_NEAR(norm(w.f_friction), 0.5 * 4.0, 1e-12);  // slides on the cone
  EXPECT_NEAR(w.p.z, 3.0, 1e-12);                     // on the tangent plane at s
  EXPECT_EQ(w.k_friction, 0.0);
  w.p_last = {8, 0, 0};  // within the radius: sticks
  friction_coulomb(prm, w);
  EXPECT_NEAR(w.f_friction.x, -0.4 * 2.0, 1e-12);
  EXPECT_EQ(w.k_friction, prm.k);
  w.f_surf = {};  // no pressing, no friction
  friction_coulomb(prm, w);
  EXPECT_EQ(w.f_friction, Vec3d{});
}

TEST(TickStages, CommitDropsNonFinitePointsAndOutputsAreMeans) {
  TickRun run;
  run.xd = {0, 0, 0};
  State st = make_state(2);
  PointWork a;
  a.x = a.xc = {1, 0, 0};
  a.f_surf = {0, 0, 2};
  a.s = a.p = a.s_last = {1, 0, 1};
  a.k_skin = 1.0;
  EXPECT_TRUE(commit_point(run, st, 0, a));
  PointWork b = a;
  b.f_surf = {0, 0, std::numeric_limits<double>::infinity()};
  EXPECT_FALSE(commit_point(run, st, 1, b));
  EXPECT_EQ(st.in_contact[1], 0);
  EXPECT_NE(run.status & kTickNonFinite, 0u);
  device_outputs(run, st);
  EXPECT_EQ(st.n_contact, 1);
  EXPECT_EQ(st.f_device, (Vec3d{0, 0, 2}));
  EXPECT_EQ(st.tau_device, cross(Vec3d{1, 0, 0}, Vec3d{0, 0, 2}));
  EXPECT_EQ(st.u, (Vec3d{0, 0, 1}));
  EXPECT_EQ(st.stiffness, 1.0);
  EXPECT_EQ(st.ticks, 1u);
}

}  // namespace
}  // namespace palp
