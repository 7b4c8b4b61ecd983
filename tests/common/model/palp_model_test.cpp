// The palp force model (ForceParams::model = palp; force_model.hpp) on tiny analytic scenes: a
// flat skin face (D_surf = 20.25 - z, outward normal +z) and bone slabs. Each change against the
// paper's model is checked on its own: the saturated skin law, the last normal past the band,
// the bone felt along the skin normal and faded in, the bone proxy as a god-object (no contact
// point inside bone), and Coulomb friction placed from positions (bounded, speed- and
// rate-independent, no creep).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "base/errors.hpp"
#include "model/force_model.hpp"
#include "prep/maps/distance_transform.hpp"
#include "support/linear_map.hpp"

namespace palp {
namespace {

constexpr double kZ0 = 20.25;  // the skin plane
constexpr double kCx = 50.0, kCy = 20.0;
const Index3 kDims{101, 41, 41};

// D(p) = a . p + b at every voxel centre, clamped to +-band (a distance map's band).
DistanceMap linear_map(Vec3d a, double b, double band = 1e9) {
  return test::linear_map(kDims, a, b, band);
}

DistanceMap flat_skin(double band = 1e9) {
  return linear_map({0, 0, -1}, kZ0, band);
}

// A bone slab over voxel rows z_lo..z_hi (and x_lo..x_hi), as signed distances of its mask.
DistanceMap bone_slab(int z_lo, int z_hi, int x_lo = 0, int x_hi = 100) {
  Grid g;
  g.dims = kDims;
  Mask m(g, 0);
  for (std::int64_t k = z_lo; k <= z_hi; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = x_lo; i <= x_hi; ++i) m.at(i, j, k) = 1;
  return signed_distance(m);
}

// The single point of finger:1 (pad at z = -8 in the tool frame) `depth` mm below the skin.
Pose press(double depth, double x = kCx, double y = kCy) {
  return Pose{{x, y, kZ0 + 8.0 - depth}, Quat{}};
}

ForceParams palp(double mu = 0.5) {
  ForceParams p = palp_params(ToolKind::Finger);
  p.mu = mu;
  return p;
}

TEST(PalpModel, SkinLawSaturatesSmoothlyAndMatchesThePaperBelow) {
  for (double d : {0.5, 2.0, 5.0}) {
    // Within 0.01 % of the paper's law where f_s is under a tenth of the cap.
    EXPECT_NEAR(saturated_surface_force(d, 30.0), surface_force(d), 1e-4 * surface_force(d));
  }
  double previous = 0.0;
  for (double d = 0.1; d < 200.0; d += 0.1) {
    const double f = saturated_surface_force(d, 30.0);
    if (d < 40.0) {
      EXPECT_GT(f, previous) << d;  // strictly monotone (beyond, it rounds to the cap)
    } else {
      EXPECT_GE(f, previous - 1e-12) << d;  // (to rounding)
    }
    EXPECT_LE(f, 30.0) << d;  // bounded by the cap
    previous = f;
  }
  EXPECT_NEAR(saturated_surface_force(60.0, 30.0), 30.0, 0.01);  // 3.9 kN in the paper's law
  const double h = 1e-6;
  EXPECT_NEAR(
      saturated_surface_force_slope(12.0, 30.0),
      (saturated_surface_force(12.0 + h, 30.0) - saturated_surface_force(12.0 - h, 30.0)) / (2 * h),
      1e-5);
}

TEST(PalpModel, PastTheBandThePointKeepsItsLastNormal) {
  // The map's band ends 10 mm deep: below it D is constant, with no gradient.
  const auto fields = std::make_shared<const FieldSampler>(flat_skin(10.0));
  const Model paper(fields, parse_tool("finger:1"));
  const Model model(fields, parse_tool("finger:1"), palp());
  State sp = make_state(paper), sm = make_state(model);
  for (double d = 1.0; d <= 15.0; d += 0.5) {
    tick(paper, sp, press(d));
    tick(model, sm, press(d));
  }
  EXPECT_LT(sp.f_device.z, 0.1);  // the paper: no skin force, a friction remnant (0.075 N)
  EXPECT_NEAR(sm.f_device.z, saturated_surface_force(10.0, 30.0), 1e-9);
  EXPECT_NEAR(sm.f_device.x, 0.0, 1e-12);
}

TEST(PalpModel, BoneIsFeltAlongTheSkinNormalAndFadedIn) {
  // A bone plate 10 mm under the skin (voxel rows z = 5..10, top surface 10.5): at depth d the
  // pad is 10.5 - ... = (kZ0 - 10.5) - d mm above it, straight below.
  const auto fields = std::make_shared<const FieldSampler>(flat_skin(), bone_slab(5, 10));
  const Model model(fields, parse_tool("finger:1"), palp());
  const double gap = kZ0 - 10.5;  // 9.75 mm
  for (double d : {0.5, 2.0, 4.0, 6.0}) {
    State st = make_state(model);
    tick(model, st, press(d));
    const double fade = d >= 4.0 ? 1.0 : (d / 4.0) * (d / 4.0) * (3.0 - 2.0 * d / 4.0);
    EXPECT_NEAR(st.f_bone[0].z, bone_force((gap - d) * 5.0 / 9.0, 40.0) * fade, 1e-3) << d;
    EXPECT_NEAR(st.f_bone[0].x, 0.0, 1e-9) << d;
  }
  // First contact brings no step: 0.01 mm in, the bone adds under 0.001 N (paper: 2.47 N).
  State st = make_state(model);
  tick(model, st, press(0.01));
  EXPECT_LT(st.f_bone[0].z, 1e-3);
  const Model paper(fields, parse_tool("finger:1"));
  State sp = make_state(paper);
  tick(paper, sp, press(0.01));
  EXPECT_GT(sp.f_bone[0].z, 2.0);
}

TEST(PalpModel, BoneBesideTheFingerIsNotFeltAsBoneBeneath) {
  // Bone only at x >= 56 (a rib's flank 5.5 mm to the side), as deep as the skin goes: the
  // nearest bone is sideways, so along the skin normal there is none; the paper's law pushes
  // as hard as for bone 5.5 mm beneath.
  const auto fields = std::make_shared<const FieldSampler>(flat_skin(), bone_slab(0, 19, 56, 100));
  const Model model(fields, parse_tool("finger:1"), palp());
  const Model paper(fields, parse_tool("finger:1"));
  State sm = make_state(model), sp = make_state(paper);
  tick(model, sm, press(6.0));
  tick(paper, sp, press(6.0));
  EXPECT_EQ(sm.f_bone[0], Vec3d{});
  EXPECT_GT(norm(sp.f_bone[0]), 10.0);
}

TEST(PalpModel, AnIntercostalSpaceIsNotFeltAsBoneBeneath) {
  // Two ribs (voxel columns x 38..42 and 58..62, rows z 10..13: top 13.5, flanks at 42.5 and
  // 57.5) and the pad 2 mm deep over each rib and midway between them. Midway the distance
  // field's gradient is the bisector of both ribs and points straight up, so the nearest bone's
  // tangent plane (dist / cos) lies beneath as if over a rib: the paper's law there pushes with
  // f_b(|D_bone|). Along the skin normal the ray passes between the ribs and leaves the grid:
  // the bone-beneath map reads its cap (80 mm), so midway the bone law gives next to nothing
  // (under f_b(40 mm) = 0.04 N before the fade; dist / cos: 2 N).
  Grid g;
  g.dims = kDims;
  Mask ribs(g, 0);
  for (std::int64_t k = 10; k <= 13; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i : {38, 39, 40, 41, 42, 58, 59, 60, 61, 62}) ribs.at(i, j, k) = 1;
  const auto fields = std::make_shared<const FieldSampler>(flat_skin(), signed_distance(ribs));
  ForceParams printed_reach = palp();
  printed_reach.bone_reach_mm = 5.0;  // the geometry alone, with the printed law's reach
  const Model model(fields, parse_tool("finger:1"), printed_reach);
  const Model paper(fields, parse_tool("finger:1"));
  const double fade = 0.5;  // smoothstep(2 / 4)
  State over = make_state(model), between = make_state(model), sp = make_state(paper);
  tick(model, over, press(2.0, 40.0));
  tick(model, between, press(2.0, 50.0));
  tick(paper, sp, press(2.0, 50.0));
  const double gap = kZ0 - 2.0 - 13.5;  // 4.75 mm above the rib's top
  EXPECT_NEAR(over.f_bone[0].z, bone_force(gap, 40.0) * fade, 0.05 * bone_force(gap, 40.0));
  EXPECT_GE(between.f_bone[0].z, 0.0);
  EXPECT_LT(between.f_bone[0].z, bone_force(40.0, 40.0) * fade);
  EXPECT_NEAR(between.f_bone[0].x, 0.0, 1e-9);
  // The paper's law midway: the voxelised distance to a rib's corner (10.7 mm), straight up.
  EXPECT_GT(sp.f_bone[0].z, bone_force(12.0, 40.0));
  EXPECT_GT(sp.f_bone[0].z, 5.0 * between.f_bone[0].z);
}

TEST(PalpModel, NoContactPointEverInsideBone) {
  // A thin plate (rows 10..13, top 6.75 mm under the skin) pushed through at 0.5 mm a tick down
  // to 16 mm, far past its bottom: the contact point stays on the plate's top, the force grows
  // with the push, and no tick reports a point inside bone.
  const auto fields = std::make_shared<const FieldSampler>(flat_skin(), bone_slab(10, 13));
  const Model model(fields, parse_tool("finger:1"), palp());
  const double top = kZ0 - 13.5;
  State st = make_state(model);
  double previous = 0.0;
  for (double d = 0.5; d <= 16.0; d += 0.5) {
    tick(model, st, press(d));
    EXPECT_EQ(st.status & kTickInsideBone, 0u) << d;
    EXPECT_LE(fields->sample_bone(st.x[0]).value, 1e-9) << d;
    if (d > top) {
      EXPECT_NEAR(st.x[0].z, 13.5, 1e-6) << d;  // held on the entry plane
      EXPECT_NEAR(st.f_bone[0].z, 40.0 + 10.0 * (d - top), 1e-6) << d;
    }
    EXPECT_GE(st.f_device.z, previous - 1e-9) << d;
    previous = st.f_device.z;
  }
}

TEST(PalpModel, InterleavedMapsTickExactlyAsSeparateOnes) {
  // palp's default layout (interleaved records, both maps sampled in one pass) against separate
  // float maps: every output of every tick equal, through contact, bone entry, the held point
  // and release.
  const DistanceMap skin = flat_skin(), bone = bone_slab(10, 13);
  const auto separate = std::make_shared<const FieldSampler>(
      skin, bone, SamplerConfig{GradientScheme::PrecomputedField, Storage::Float32});
  const auto interleaved = std::make_shared<const FieldSampler>(
      skin, bone, SamplerConfig{GradientScheme::PrecomputedField, Storage::Interleaved});
  const Model a(separate, parse_tool("finger:7"), palp());
  const Model b(interleaved, parse_tool("finger:7"), palp());
  State sa = make_state(a), sb = make_state(b);
  int latched = 0;
  for (int t = 0; t < 200; ++t) {
    // down to 14 mm (through the plate's top at 6.75 mm) while sliding, then back out
    const double d = t < 100 ? 0.14 * t : 0.14 * (200 - t);
    const Pose pose = press(d, kCx - 10.0 + 0.1 * t, kCy + 0.03 * t);
    tick(a, sa, pose);
    tick(b, sb, pose);
    ASSERT_EQ(sa.status, sb.status) << t;
    EXPECT_EQ(sa.f_device, sb.f_device) << t;
    EXPECT_EQ(sa.tau_device, sb.tau_device) << t;
    EXPECT_EQ(sa.stiffness, sb.stiffness) << t;
    EXPECT_EQ(sa.x, sb.x) << t;
    EXPECT_EQ(sa.p, sb.p) << t;
    latched += (sa.status & kTickBoneLatched) != 0;
  }
  EXPECT_GT(latched, 10);  // the bone proxy was exercised
}

TEST(PalpModel, NoContactPointInsideARoundRibMetFromAnySide) {
  // A round rib (radius 3 mm about x = 50, z = 10, voxelised at 1 mm) met by a point moving in
  // straight lines from the skin side at angles from straight down to sideways, 0.25 mm a tick,
  // 8 mm past the rib's centre: the held point is never inside the voxelised rib, whose
  // staircase the entry plane (through the distance field's estimate of the entry point) can
  // cut into on either side.
  Grid g;
  g.dims = kDims;
  Mask rib(g, 0);
  for (std::int64_t k = 0; k < kDims[2]; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = 40; i <= 60; ++i)
        if (std::hypot(i - 50.0, k - 10.0) <= 3.0) rib.at(i, j, k) = 1;
  const auto fields = std::make_shared<const FieldSampler>(flat_skin(), signed_distance(rib));
  const Model model(fields, parse_tool("finger:1"), palp());
  const double pi = 3.14159265358979323846;
  for (int deg = 0; deg <= 80; deg += 10) {
    for (double offset : {-2.0, -1.0, 0.0, 1.0, 2.0}) {
      const Vec3d dir{std::sin(deg * pi / 180.0), 0.0, -std::cos(deg * pi / 180.0)};
      const Vec3d aim{50.0 + offset * dir.z, kCy, 10.0 - offset * dir.x};  // offset across dir
      State st = make_state(model);
      for (double s = -14.0; s <= 8.0; s += 0.25) {
        const Vec3d pad = aim + s * dir;
        if (pad.z > kZ0 - 0.5) continue;
        tick(model, st, Pose{{pad.x, pad.y, pad.z + 8.0}, Quat{}});
        ASSERT_LE(fields->sample_bone(st.x[0]).value, 1e-9) << deg << " " << offset << " " << s;
        ASSERT_EQ(st.status & kTickInsideBone, 0u) << deg << " " << offset << " " << s;
      }
    }
  }
}

TEST(PalpModel, FrictionIsACoulombConeAndIndependentOfSpeedAndRate) {
  const auto fields = std::make_shared<const FieldSampler>(flat_skin());
  for (double mu : {0.3, 0.5, 0.8}) {
    const Model model(fields, parse_tool("finger:1"), palp(mu));
    const double f_n = saturated_surface_force(4.0, 30.0);
    // Slide 10 mm sideways at 4 mm depth in steps of 0.01, 0.1 and 1 mm (speeds or rates 100x
    // apart): the same friction at the end, exactly mu f_n, opposing the slide.
    for (double step : {0.01, 0.1, 1.0}) {
      State st = make_state(model);
      tick(model, st, press(4.0));
      double largest = 0.0;
      for (double x = 0.0; x <= 10.0 + 1e-9; x += step) {
        tick(model, st, press(4.0, kCx + x));
        largest = std::max(largest, norm(st.f_friction[0]));
      }
      EXPECT_NEAR(st.f_friction[0].x, -mu * f_n, 1e-9) << mu << " " << step;
      EXPECT_LE(largest, mu * f_n + 1e-9) << mu << " " << step;
    }
  }
}

TEST(PalpModel, NoFrictionWithoutPressingAndNoCreepUnderJitter) {
  const auto fields = std::make_shared<const FieldSampler>(flat_skin());
  const Model model(fields, parse_tool("finger:1"), palp());
  for (double depth : {1.0, 2.0, 3.0, 5.0, 8.0}) {
    State st = make_state(model);
    tick(model, st, press(depth));
    const Vec3d proxy = st.p[0];
    // Jitter of a tenth of the stick radius mu f_n / k (0.03 mm at 1 mm deep, 5.6 mm at 8 mm),
    // 1000 ticks: the proxy does not move.
    const double radius = 0.5 * saturated_surface_force(depth, 30.0) / 0.4;
    for (int n = 0; n < 1000; ++n) {
      const double jx = 0.1 * radius * std::sin(n * 0.7), jy = 0.1 * radius * std::cos(n * 1.3);
      tick(model, st, press(depth, kCx + jx, kCy + jy));
    }
    tick(model, st, press(depth));
    EXPECT_NEAR(st.p[0].x, proxy.x, 1e-12) << depth;
    EXPECT_NEAR(st.p[0].y, proxy.y, 1e-12) << depth;
  }
  // Touching without pressing (0.001 mm deep): f_n ~ 2e-7 N, so a slide meets no friction.
  State st = make_state(model);
  tick(model, st, press(0.001));
  tick(model, st, press(0.001, kCx + 1.0));
  EXPECT_LT(norm(st.f_friction[0]), 1e-6);
}

TEST(PalpModel, PaperIsTheDefaultAndPalpIsNamed) {
  EXPECT_EQ(ForceParams{}.model, ModelKind::Paper);
  EXPECT_EQ(default_params(ToolKind::Finger).model, ModelKind::Paper);
  EXPECT_EQ(palp_params(ToolKind::Finger).model, ModelKind::Palp);
  EXPECT_EQ(palp_params(ToolKind::Finger).bone_mode, BoneMode::Robust);
  EXPECT_EQ(palp_params(ToolKind::Finger).bone_reach_mm, 9.0);  // the rib-contrast study's choice
  EXPECT_EQ(palp_params(ToolKind::Probe).bone_reach_mm, 9.0);
  EXPECT_EQ(palp_params(ToolKind::Probe).mu, 0.2);
  EXPECT_EQ(parse_model_kind("palp"), ModelKind::Palp);
  EXPECT_STREQ(to_string(ModelKind::Paper), "paper");
  EXPECT_THROW(parse_model_kind("best"), UsageError);
}

}  // namespace
}  // namespace palp
