// The bone levels from the scan's own histogram (common/prep/segment/hu_levels.cpp): the
// soft-tissue peak found, followed within +-40 HU, refused beyond; and what it is for: a scan whose
// HU are all shifted (a calibration offset) gets the same bone mask as the unshifted one, where
// fixed levels give another.
#include "prep/segment/hu_levels.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "prep/segment/segmentation.hpp"

namespace palp {
namespace {

// A 40^3 body: soft tissue at `soft` HU (+-7 HU deterministic ripple) with a fat layer at `fat`.
CtVolume block(int soft, int fat = -100) {
  Grid g;
  g.dims = {40, 40, 40};
  CtVolume ct(g, static_cast<std::int16_t>(fat));
  for (std::int64_t k = 0; k < 40; ++k)
    for (std::int64_t j = 0; j < 40; ++j)
      for (std::int64_t i = 10; i < 40; ++i)
        ct.at(i, j, k) =
            static_cast<std::int16_t>(soft + static_cast<int>((i + 3 * j + 7 * k) % 15) - 7);
  return ct;
}

TEST(HuLevels, FindsThePeakAndShiftsTheLevelsByItsOffset) {
  const CtVolume ct = block(50);
  const Mask body(ct.grid, 1);
  const HuLevels at50 = estimate_hu_levels(ct, body);
  ASSERT_TRUE(at50.peak_found);
  EXPECT_NEAR(at50.soft_peak_hu, 50.0, 4.0);  // the ripple's flat top: its first HU
  EXPECT_NEAR(at50.peak_share, 0.75, 1e-9);   // the fat column x < 10 is the rest
  ASSERT_TRUE(at50.fat_found);
  EXPECT_NEAR(at50.fat_peak_hu, -100.0, 4.0);  // the first HU of the smoothed flat top
  EXPECT_NEAR(at50.fat_share, 0.25, 1e-9);
  // A calibration offset: fat and soft tissue both 30 HU up.
  const HuLevels at80 = estimate_hu_levels(block(80, -70), body);
  EXPECT_EQ(at80.soft_peak_hu - at50.soft_peak_hu, 30.0);
  EXPECT_EQ(at80.offset_hu, at80.soft_peak_hu - 50.0);
  EXPECT_EQ(at80.levels.seed_hu, 300.0 + at80.offset_hu);
  EXPECT_EQ(at80.levels.grow_hu, 150.0 + at80.offset_hu);
  EXPECT_EQ(at80.levels.iso_hu, 200.0 + at80.offset_hu);
  EXPECT_TRUE(at80.note.empty());
}

// Contrast: the soft tissue up, fat where it was. The levels go up only as far as fat went up
// (bone, like fat, does not enhance); down they follow the soft tissue alone.
TEST(HuLevels, SoftTissueRaisedWithoutFatDoesNotRaiseTheLevels) {
  const Mask body(block(0).grid, 1);
  const HuLevels at50 = estimate_hu_levels(block(50), body);
  const HuLevels contrast = estimate_hu_levels(block(80), body);
  EXPECT_EQ(contrast.soft_peak_hu - at50.soft_peak_hu, 30.0);
  EXPECT_EQ(contrast.offset_hu, 0.0);
  EXPECT_EQ(contrast.levels.grow_hu, 150.0);
  EXPECT_NE(contrast.note.find("contrast"), std::string::npos) << contrast.note;
  const HuLevels partly = estimate_hu_levels(block(80, -85), body);  // fat 15 HU up
  EXPECT_EQ(partly.offset_hu, partly.fat_peak_hu + 100.0);
  EXPECT_NEAR(partly.offset_hu, 15.0, 4.0);
  const HuLevels lower = estimate_hu_levels(block(20), body);  // soft tissue down, fat not
  EXPECT_EQ(lower.offset_hu, lower.soft_peak_hu - 50.0);
  EXPECT_LT(lower.offset_hu, -20.0);
  EXPECT_TRUE(lower.note.empty());
  // No fat to confirm a rise: not followed.
  CtVolume lean = block(80, 40);
  for (std::int64_t k = 0; k < 40; ++k)
    for (std::int64_t j = 0; j < 40; ++j)
      for (std::int64_t i = 0; i < 10; ++i) lean.at(i, j, k) = 600;  // bone, not fat
  const HuLevels no_fat = estimate_hu_levels(lean, body);
  EXPECT_FALSE(no_fat.fat_found);
  EXPECT_EQ(no_fat.offset_hu, 0.0);
  EXPECT_NE(no_fat.note.find("fat not found"), std::string::npos) << no_fat.note;
}

TEST(HuLevels, APeakFarFromSoftTissueIsNotFollowed) {
  const Mask body(block(0).grid, 1);
  const HuLevels far = estimate_hu_levels(block(140), body);  // e.g. a contrast-filled organ
  EXPECT_TRUE(far.peak_found);
  EXPECT_EQ(far.offset_hu, 0.0);
  EXPECT_EQ(far.levels.seed_hu, 300.0);
  EXPECT_NE(far.note.find("more than 40 HU"), std::string::npos);

  CtVolume fat = block(0);
  std::fill(fat.data.begin(), fat.data.end(), std::int16_t{-100});
  const HuLevels none = estimate_hu_levels(fat, body);
  EXPECT_FALSE(none.peak_found);
  EXPECT_EQ(none.levels.grow_hu, 150.0);
  EXPECT_NE(none.note.find("no soft-tissue peak"), std::string::npos);
  Grid small;
  small.dims = {2, 2, 2};
  EXPECT_THROW(estimate_hu_levels(fat, Mask(small, 0)), UsageError);
}

// Bone mask of `ct` with levels adapted (as prep does) or fixed.
Mask bone_of(const CtVolume& ct, const Mask& body, bool adapt) {
  SegmentationParams p;
  if (adapt) {
    const HuLevels h = estimate_hu_levels(ct, body);
    p.bone_seed_hu = h.levels.seed_hu;
    p.bone_grow_hu = h.levels.grow_hu;
  }
  return segment_bone(ct, body, p);
}

TEST(HuLevels, AShiftedScanGetsTheSameBoneMask) {
  // The torso phantom, and the same scan with every HU 30 higher (soft tissue 40 -> 70 HU, within
  // the 40 HU the levels follow). Its bone is the same; adapted levels find it voxel for voxel,
  // the fixed ones grow into more of the partial-volume rim.
  const CtVolume ct = read_ct("phantom:torso");
  CtVolume shifted = ct;
  for (auto& v : shifted.data) v = static_cast<std::int16_t>(std::min(3071, v + 30));
  const SegmentationParams p;
  const Mask body = segment_body(ct, p);
  const Mask adapted = bone_of(ct, body, true), adapted_shifted = bone_of(shifted, body, true);
  const Mask fixed_shifted = bone_of(shifted, body, false);
  std::size_t differ_adapted = 0, differ_fixed = 0, bone = 0;
  for (std::size_t n = 0; n < body.data.size(); ++n) {
    bone += adapted.data[n] != 0;
    differ_adapted += adapted.data[n] != adapted_shifted.data[n];
    differ_fixed += adapted.data[n] != fixed_shifted.data[n];
  }
  std::printf("bone %zu voxels; shifted by 30 HU: %zu differ with adapted levels, %zu with fixed\n",
              bone, differ_adapted, differ_fixed);
  ASSERT_GT(bone, 1000u);
  EXPECT_EQ(differ_adapted, 0u);
  EXPECT_GT(differ_fixed, 0u);
}

TEST(HuLevels, TheSharedCtsPeak) {
  const std::string path = std::string(PALP_SHARED_DATA_DIR) + "/ct_abdomen_3mm.nii.gz";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no shared CT at " << path;
  const CtVolume ct = read_ct(path);
  const Mask body = segment_body(ct, SegmentationParams{});
  const HuLevels h = estimate_hu_levels(ct, body);
  std::printf("shared CT: soft-tissue peak %.0f HU (%.1f %% of the body), offset %+.0f HU\n",
              h.soft_peak_hu, 100.0 * h.peak_share, h.offset_hu);
  EXPECT_TRUE(h.peak_found);
  EXPECT_TRUE(h.note.empty());
}

}  // namespace
}  // namespace palp
