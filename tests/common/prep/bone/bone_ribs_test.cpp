// Ribs without a seed (common/prep/bone/bone_ribs.cpp), through segment_bone on a tiny inline scene
// at 1 mm (soft tissue 40 HU, 90 x 90 mm across): a rib blurred under the seed level (a 240 HU core
// in a 170 HU rim: nothing reaches 300 HU) under the body's surface is bone; objects at the same HU
// that reach the growing level without a seed are not: an enhanced vessel of the same shape deep
// in the body, a superficial rod of the same HU along a gas pocket (a sharp kernel's overshoot at
// a bowel loop) and a superficial enhanced muscle too thick for a rib. With the rule off
// (bone_rib_depth_mm 0) the rib is not bone either: nothing in the scene seeds.
#include <gtest/gtest.h>

#include <cstdint>

#include "base/errors.hpp"
#include "prep/segment/segmentation.hpp"
#include "support/tissue_scene.hpp"

namespace palp {
namespace {

using testing::bone_of;
using testing::box;
using testing::count_in;
using testing::tissue_scene;

// A rod of [lo, hi) at 170 HU with a 240 HU core 2 mm in from its sides (along each axis at most
// 10 mm long): the blurred profile of a thin bone whose peak fell under the seed level.
void blurred_rod(CtVolume& ct, Index3 lo, Index3 hi) {
  box(ct, lo, hi, 170);
  Index3 core_lo = lo, core_hi = hi;
  for (int a = 0; a < 3; ++a)
    if (hi[a] - lo[a] <= 10) core_lo[a] += 2, core_hi[a] -= 2;
  box(ct, core_lo, core_hi, 240);
}

TEST(BoneRibs, ABlurredRibUnderTheSurfaceIsBoneAVesselGasRodOrMuscleIsNot) {
  CtVolume ct = tissue_scene();
  const Index3 rib_lo = {20, 10, 26}, rib_hi = {80, 18, 34};  // 60 x 8 x 8 mm, 6-14 mm deep
  blurred_rod(ct, rib_lo, rib_hi);
  // The same profile along the body axis in the middle, 42 mm or more from the outside.
  const Index3 vessel_lo = {46, 46, 10}, vessel_hi = {54, 54, 50};
  blurred_rod(ct, vessel_lo, vessel_hi);
  // The same rod 20-28 mm deep, along a gas pocket.
  const Index3 gas_rod_lo = {20, 24, 40}, gas_rod_hi = {80, 32, 48};
  box(ct, {20, 20, 40}, {80, 24, 48}, -900);
  blurred_rod(ct, gas_rod_lo, gas_rod_hi);
  // A muscle enhanced to the same HU, 4-29 mm deep: 60 x 25 x 20 mm.
  const Index3 muscle_lo = {20, 66, 36}, muscle_hi = {80, 91, 56};
  box(ct, muscle_lo, muscle_hi, 200);

  const Mask with = bone_of(ct);
  EXPECT_EQ(count_in(with, rib_lo, rib_hi), 60 * 8 * 8);
  EXPECT_EQ(count_in(with, vessel_lo, vessel_hi), 0);
  EXPECT_EQ(count_in(with, gas_rod_lo, gas_rod_hi), 0);
  EXPECT_EQ(count_in(with, muscle_lo, muscle_hi), 0);
  EXPECT_EQ(count_in(with, {0, 0, 0}, {100, 100, 60}), 60 * 8 * 8) << "bone beyond the rib";

  SegmentationParams off;
  off.bone_rib_depth_mm = 0.0;
  EXPECT_EQ(count_in(bone_of(ct, off), {0, 0, 0}, {100, 100, 60}), 0);
  // The vessel is a rib to a rule that reaches 45 mm deep: the depth is what keeps it out.
  SegmentationParams deep;
  deep.bone_rib_depth_mm = 45.0;
  EXPECT_EQ(count_in(bone_of(ct, deep), vessel_lo, vessel_hi), 8 * 8 * 40);
  // With the gas pocket filled with tissue the rod along it is a rib: the gas is what keeps it out.
  box(ct, {20, 20, 40}, {80, 24, 48}, 40);
  EXPECT_EQ(count_in(bone_of(ct), gas_rod_lo, gas_rod_hi), 60 * 8 * 8);
}

TEST(BoneRibs, OutOfRangeDepthIsRefused) {
  const CtVolume ct = tissue_scene();
  for (const double bad : {-1.0, 201.0}) {
    SegmentationParams p;
    p.bone_rib_depth_mm = bad;
    EXPECT_THROW(bone_of(ct, p), UsageError) << bad;
  }
}

}  // namespace
}  // namespace palp
