// The contrast phase from trunk cores (common/prep/vessel/vessel_phase.cpp) on masks built here:
// a 90 x 90 x 60 mm grid at 1.5 mm, the body axis along k, soft tissue at 50 HU. Cores are rods
// 6 mm across along the body axis (tubes: 60 mm long, ten times as long as across) or a ball
// 15 mm across (roundish: no tube). Expectations from the geometry and the levels painted.
#include "prep/vessel/vessel_phase.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "prep/vessel/vessel_segmentation.hpp"

namespace palp {
namespace {

constexpr double kSoftHu = 50.0;

struct Cores {
  Mask mask;
  std::vector<std::int16_t> hu;
};

Cores empty() {
  Grid g;
  g.dims = {60, 60, 40};
  g.spacing = {1.5, 1.5, 1.5};
  return {Mask(g, 0, "trunk cores"), std::vector<std::int16_t>(g.voxel_count(), 50)};
}

// A rod 6 mm across along k through in-plane (x, y) mm, slices [k0, k1), at `hu`.
void rod(Cores& c, double x, double y, std::int64_t k0, std::int64_t k1, std::int16_t hu) {
  const Grid& g = c.mask.grid;
  for (std::int64_t k = k0; k < k1; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i)
        if (std::hypot(static_cast<double>(i) * 1.5 - x, static_cast<double>(j) * 1.5 - y) <= 3.0) {
          c.mask.at(i, j, k) = 1;
          c.hu[g.linear(i, j, k)] = hu;
        }
}

TEST(ContrastPhase, OneTubeAtTheAortasLevelIsArterial) {
  Cores c = empty();
  rod(c, 30.0, 45.0, 0, 40, 400);
  const ContrastPhase p = read_contrast_phase(c.mask, c.hu, kSoftHu, 400.0, {});
  EXPECT_EQ(p.name, "arterial");
  EXPECT_EQ(p.second_trunk_hu, 0.0);
  EXPECT_EQ(p.tube_hu, 400.0);
}

TEST(ContrastPhase, TwoTubesSideBySideAtItsLevelArePortalVenous) {
  // The aorta and a vena cava 30 mm to its side, filled nearly as well: the darker one's level.
  Cores c = empty();
  rod(c, 30.0, 45.0, 0, 40, 400);
  rod(c, 60.0, 45.0, 0, 40, 380);
  const ContrastPhase p = read_contrast_phase(c.mask, c.hu, kSoftHu, 400.0, {});
  EXPECT_EQ(p.name, "portal-venous");
  EXPECT_EQ(p.second_trunk_hu, 380.0);
  EXPECT_EQ(p.tube_hu, 400.0) << "the brighter tube's";
}

TEST(ContrastPhase, ATubeBelowHalfTheAortasHeightIsAnUnfilledVein) {
  // Half way from 50 to 400 HU is 225: a vein at 200 HU has not filled yet.
  Cores c = empty();
  rod(c, 30.0, 45.0, 0, 40, 400);
  rod(c, 60.0, 45.0, 0, 40, 200);
  EXPECT_EQ(read_contrast_phase(c.mask, c.hu, kSoftHu, 400.0, {}).name, "arterial");
}

TEST(ContrastPhase, TubesOneAboveTheOtherAreOneTrunk) {
  // Two pieces of one trunk sharing no slice, whatever their offset across.
  Cores c = empty();
  rod(c, 30.0, 45.0, 0, 18, 400);
  rod(c, 60.0, 45.0, 20, 40, 400);
  EXPECT_EQ(read_contrast_phase(c.mask, c.hu, kSoftHu, 400.0, {}).name, "arterial");
}

TEST(ContrastPhase, WithoutATubeTheLumensLevelDecides) {
  // A ball's core (a chamber, a kidney) is no tube: 170 HU above the soft tissue or more reads
  // arterial, less portal-venous.
  Cores c = empty();
  const Grid& g = c.mask.grid;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i)
        if (std::hypot(static_cast<double>(i) - 30.0, static_cast<double>(j) - 30.0,
                       static_cast<double>(k) - 20.0) <= 5.0)
          c.mask.at(i, j, k) = 1;
  const ContrastPhase p = read_contrast_phase(c.mask, c.hu, kSoftHu, kSoftHu + 170.0, {});
  EXPECT_EQ(p.name, "arterial");
  EXPECT_EQ(p.tube_hu, 0.0) << "no tube";
  EXPECT_EQ(read_contrast_phase(c.mask, c.hu, kSoftHu, kSoftHu + 169.0, {}).name, "portal-venous");
}

}  // namespace
}  // namespace palp
