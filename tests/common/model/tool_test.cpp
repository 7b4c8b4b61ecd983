// Tool layouts (spec "Tools"): counts, ring radii and azimuths, pad centres, probe grid, and the
// strings that are refused.
#include "model/tool.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "base/errors.hpp"

namespace palp {
namespace {

TEST(Tool, FingerCountsAndRings) {
  for (int n : {1, 7, 19, 37}) {
    const Tool t = parse_tool("finger:" + std::to_string(n));
    EXPECT_EQ(t.kind, ToolKind::Finger);
    EXPECT_EQ(t.name, "finger:" + std::to_string(n));
    EXPECT_EQ(t.per_pad, n);
    ASSERT_EQ(t.points.size(), static_cast<std::size_t>(n));
    EXPECT_EQ(t.points[0], (Vec3d{0.0, 0.0, -8.0}));
    // Ring r holds 6r points at radius 2.5 r, azimuth 2 pi j / (6r), in that order.
    std::size_t idx = 1;
    for (int r = 1; idx < t.points.size(); ++r) {
      for (int j = 0; j < 6 * r; ++j, ++idx) {
        const Vec3d& p = t.points[idx];
        EXPECT_DOUBLE_EQ(p.z, -8.0);
        EXPECT_NEAR(std::hypot(p.x, p.y), 2.5 * r, 1e-12);
        const double phi = 2.0 * std::numbers::pi * j / (6 * r);
        EXPECT_NEAR(p.x, 2.5 * r * std::cos(phi), 1e-12);
        EXPECT_NEAR(p.y, 2.5 * r * std::sin(phi), 1e-12);
      }
    }
    EXPECT_EQ(idx, t.points.size());
  }
}

TEST(Tool, RingsAreBalancedAboutTheCentre) {
  const Tool t = parse_tool("finger:37");
  Vec3d sum{};
  for (const Vec3d& p : t.points) sum += p;
  EXPECT_NEAR(sum.x, 0.0, 1e-12);
  EXPECT_NEAR(sum.y, 0.0, 1e-12);
  EXPECT_NEAR(sum.z, -8.0 * 37, 1e-12);
}

TEST(Tool, TwoFingerPadsAtPlusMinus9_5) {
  for (int n : {1, 7, 19, 37}) {
    const Tool t = parse_tool("twofinger:" + std::to_string(n));
    EXPECT_EQ(t.kind, ToolKind::TwoFinger);
    ASSERT_EQ(t.points.size(), static_cast<std::size_t>(2 * n));
    EXPECT_EQ(t.points[0], (Vec3d{-9.5, 0.0, -8.0}));
    EXPECT_EQ(t.points[static_cast<std::size_t>(n)], (Vec3d{9.5, 0.0, -8.0}));
    const Tool single = parse_tool("finger:" + std::to_string(n));
    for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i) {
      EXPECT_NEAR(t.points[i].x, single.points[i].x - 9.5, 1e-12);
      EXPECT_NEAR(t.points[i + static_cast<std::size_t>(n)].x, single.points[i].x + 9.5, 1e-12);
      EXPECT_DOUBLE_EQ(t.points[i].y, single.points[i].y);
    }
  }
}

TEST(Tool, ProbeGrid) {
  const Tool t = parse_tool("probe:9x3");
  EXPECT_EQ(t.kind, ToolKind::Probe);
  EXPECT_EQ(t.nx, 9);
  EXPECT_EQ(t.ny, 3);
  ASSERT_EQ(t.points.size(), 27u);
  // x fastest: -20, -15, ..., 20; y -6, 0, 6; all on z = -50.
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 9; ++i) {
      const Vec3d& p = t.points[static_cast<std::size_t>(j * 9 + i)];
      EXPECT_DOUBLE_EQ(p.x, -20.0 + 5.0 * i);
      EXPECT_DOUBLE_EQ(p.y, -6.0 + 6.0 * j);
      EXPECT_DOUBLE_EQ(p.z, -50.0);
    }
}

TEST(Tool, ProbeSingleRowAndColumnSitAtZero) {
  const Tool row = parse_tool("probe:5x1");
  ASSERT_EQ(row.points.size(), 5u);
  for (const Vec3d& p : row.points) EXPECT_EQ(p.y, 0.0);
  EXPECT_EQ(row.points.front().x, -20.0);
  EXPECT_EQ(row.points.back().x, 20.0);
  const Tool col = parse_tool("probe:1x4");
  ASSERT_EQ(col.points.size(), 4u);
  for (const Vec3d& p : col.points) EXPECT_EQ(p.x, 0.0);
  EXPECT_EQ(col.points.front().y, -6.0);
  EXPECT_EQ(col.points.back().y, 6.0);
  const Tool one = parse_tool("probe:1x1");
  ASSERT_EQ(one.points.size(), 1u);
  EXPECT_EQ(one.points[0], (Vec3d{0.0, 0.0, -50.0}));
}

TEST(Tool, Defaults) {
  EXPECT_EQ(parse_tool("finger").name, "finger:37");
  EXPECT_EQ(parse_tool("twofinger").points.size(), 74u);
  EXPECT_EQ(parse_tool("probe").name, "probe:9x3");
}

TEST(Tool, RefusesBadStrings) {
  for (const char* bad :
       {"",          "finger:",   "finger:0",    "finger:2",    "finger:36",       "finger:-7",
        "finger:+7", "finger: 7", "finger:7x",   "finger:37:1", "twofinger:8",     "probe:",
        "probe:9",   "probe:0x3", "probe:9x0",   "probe:101x3", "probe:9x1000000", "probe:x3",
        "probe:9x",  "probe:9X3", "probe:9x3x1", "hand:1",      "Finger:7",        "finger7"}) {
    EXPECT_THROW(parse_tool(bad), UsageError) << bad;
  }
}

}  // namespace
}  // namespace palp
