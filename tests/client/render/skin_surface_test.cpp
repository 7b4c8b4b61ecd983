// The skin preset's scalar (client/render/skin_surface.hpp), without a display: the ramp's width,
// the smoothing pass against fields whose smoothing is known in closed form (a plane's distance
// is kept, what alternates from node to node is removed, x^2 gains h^2 / 2), the composed
// scalar's value on a plane's distance, and which scalar each preset takes.
#include "render/skin_surface.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "base/errors.hpp"

namespace palp::view {
namespace {

constexpr std::array<std::int64_t, 3> kDims{6, 5, 7};

std::size_t at(std::int64_t i, std::int64_t j, std::int64_t k) {
  return static_cast<std::size_t>(i + kDims[0] * (j + kDims[1] * k));
}

// The signed distance to the plane 0.6 x + 0.8 z = 9 (mm; positive on the side of larger x, z)
// at node (i, j, k) of a grid of spacing h.
double plane_distance(std::int64_t i, std::int64_t k, double h) {
  return 0.6 * static_cast<double>(i) * h + 0.8 * static_cast<double>(k) * h - 9.0;
}

TEST(SkinSurface, TheRampCoversTwoVoxelDiagonals) {
  EXPECT_NEAR(skin_ramp_half_width_mm({3, 3, 3}), 2.0 * std::sqrt(27.0), 1e-12);
  EXPECT_NEAR(skin_ramp_half_width_mm({0.8, 0.8, 3}), 2.0 * std::sqrt(0.64 + 0.64 + 9.0), 1e-12);
  // Fine voxels: never narrower than the pseudo-density's ramp.
  EXPECT_EQ(skin_ramp_half_width_mm({0.5, 0.5, 0.5}), kRampHalfWidthMm);
}

TEST(SkinSurface, SmoothingKeepsAPlanesDistance) {
  std::vector<float> d(kDims[0] * kDims[1] * kDims[2]);
  for (std::int64_t k = 0; k < kDims[2]; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = 0; i < kDims[0]; ++i)
        d[at(i, j, k)] = static_cast<float>(plane_distance(i, k, 3.0));
  const std::vector<float> before = d;
  smooth_distance(d, kDims);
  for (std::size_t n = 0; n < d.size(); ++n) EXPECT_NEAR(d[n], before[n], 1e-5) << n;
}

TEST(SkinSurface, SmoothingRemovesWhatAlternatesFromNodeToNode) {
  // 5 mm, with +-0.3 mm errors changing sign from each node to the next along every axis.
  std::vector<float> d(kDims[0] * kDims[1] * kDims[2]);
  for (std::int64_t k = 0; k < kDims[2]; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = 0; i < kDims[0]; ++i)
        d[at(i, j, k)] = (i + j + k) % 2 == 0 ? 5.3f : 4.7f;
  smooth_distance(d, kDims);
  // Inside the grid (the ends extrapolate linearly, which keeps an end node's own error).
  for (std::int64_t k = 1; k + 1 < kDims[2]; ++k)
    for (std::int64_t j = 1; j + 1 < kDims[1]; ++j)
      for (std::int64_t i = 1; i + 1 < kDims[0]; ++i)
        EXPECT_NEAR(d[at(i, j, k)], 5.0f, 1e-5) << i << "," << j << "," << k;
}

TEST(SkinSurface, SmoothingMovesACurvedFieldByHSquaredOver4TimesItsSecondDerivative) {
  // d = x^2 (x = i h, h = 3 mm), d_xx = 2: inside the grid the pass adds h^2 / 4 * 2 = 4.5.
  constexpr double h = 3.0;
  std::vector<float> d(kDims[0] * kDims[1] * kDims[2]);
  for (std::int64_t k = 0; k < kDims[2]; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = 0; i < kDims[0]; ++i)
        d[at(i, j, k)] = static_cast<float>(std::pow(static_cast<double>(i) * h, 2));
  smooth_distance(d, kDims);
  for (std::int64_t i = 1; i + 1 < kDims[0]; ++i)
    EXPECT_NEAR(d[at(i, 2, 3)], std::pow(static_cast<double>(i) * h, 2) + h * h / 2.0, 1e-4) << i;
}

TEST(SkinSurface, TheScalarIsTheSkinStepOnAPlanesDistance) {
  constexpr double h = 3.0;
  const double w = skin_ramp_half_width_mm({h, h, h});
  std::vector<float> d(kDims[0] * kDims[1] * kDims[2]);
  for (std::int64_t k = 0; k < kDims[2]; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = 0; i < kDims[0]; ++i)
        d[at(i, j, k)] = static_cast<float>(plane_distance(i, k, h));
  const std::vector<float> s = compose_skin_scalar(d, kDims, {h, h, h});
  for (std::int64_t k = 1; k + 1 < kDims[2]; ++k)
    for (std::int64_t i = 1; i + 1 < kDims[0]; ++i) {
      // Air -1000 and 0 deep inside, linear in between: -500 on the plane, 500 / w a millimetre.
      const double dist = plane_distance(i, k, h);
      const double expected = std::clamp(-500.0 + 500.0 * dist / w, -1000.0, 0.0);
      EXPECT_NEAR(s[at(i, 1, k)], expected, 1e-3) << i << "," << k;
    }
  // Node (1, 1, 1) lies 9 - 4.2 = 4.8 mm outside the plane, node (4, 2, 5) 7.2 + 12 - 9 =
  // 10.2 mm inside: both within the ramp (w = 10.39 mm).
  EXPECT_NEAR(s[at(1, 1, 1)], -500.0 - 500.0 * 4.8 / w, 1e-3);
  EXPECT_NEAR(s[at(4, 2, 5)], -500.0 + 500.0 * 10.2 / w, 1e-3);
  EXPECT_THROW(compose_skin_scalar(std::vector<float>(3), kDims, {h, h, h}), UsageError);
}

TEST(SkinSurface, TheSkinClosesWhereTheVolumeEnds) {
  // All inside the body (a scan's field of view cutting it): the outermost voxels are air.
  const std::vector<float> d(kDims[0] * kDims[1] * kDims[2], 50.0f);
  const std::vector<float> s = compose_skin_scalar(d, kDims, {3, 3, 3});
  for (std::int64_t k = 0; k < kDims[2]; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = 0; i < kDims[0]; ++i) {
        const bool outermost = i == 0 || j == 0 || k == 0 || i + 1 == kDims[0] ||
                               j + 1 == kDims[1] || k + 1 == kDims[2];
        EXPECT_EQ(s[at(i, j, k)], outermost ? kAirValue : 0.0f) << i << "," << j << "," << k;
      }
}

TEST(SkinSurface, TheSkinPresetStepsUpAtTheSkin) {
  const Preset p = make_skin_surface_preset();
  EXPECT_EQ(p.id, PresetId::Skin);
  EXPECT_EQ(p.window.level, -500.0);  // the scalar of d = 0
  EXPECT_TRUE(p.shade);
  // Transparent up to -501, opaque from -499.
  ASSERT_EQ(p.points.size(), 4u);
  EXPECT_EQ(point_value(p.points[1], p.window), -501.0);
  EXPECT_EQ(p.points[1].opacity, 0.0);
  EXPECT_EQ(point_value(p.points[2], p.window), -499.0);
  EXPECT_GT(p.points[2].opacity, 0.9);
  EXPECT_LT(point_value(p.points[0], p.window), kAirValue);
  EXPECT_GT(point_value(p.points[3], p.window), 0.0);
}

TEST(SkinSurface, OnlyTheSkinPresetTakesTheSubVoxelSkin) {
  EXPECT_EQ(scalar_kind(PresetId::Skin, true, false), ScalarKind::Skin);
  EXPECT_EQ(scalar_kind(PresetId::Skin, false, false), ScalarKind::Skin);
  EXPECT_EQ(scalar_kind(PresetId::Skin, true, true), ScalarKind::Hu);  // --skin-hu
  EXPECT_EQ(scalar_kind(PresetId::Skin, false, true), ScalarKind::Maps);
  EXPECT_EQ(scalar_kind(PresetId::Bone, true, false), ScalarKind::Hu);
  EXPECT_EQ(scalar_kind(PresetId::Soft, false, false), ScalarKind::Maps);
  EXPECT_EQ(make_preset_on(ScalarKind::Hu, PresetId::Skin).window.level,
            make_preset(PresetId::Skin, true).window.level);
  EXPECT_EQ(make_preset_on(ScalarKind::Skin, PresetId::Skin).window.width, kSkinStepWidth);
}

}  // namespace
}  // namespace palp::view
