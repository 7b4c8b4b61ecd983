// Compact detached islands (common/prep/bone/bone_islands.cpp), through segment_bone on a tiny
// inline scene at 1 mm: beside a skeleton (the largest island), a compact dense island that does
// not reach the scan's border (a stone, a calcified node) and lies 15 mm from other bone is
// removed, while a detached rod (a rib segment), a compact piece the scan's first slice cuts, a
// compact bone across a 4 mm joint space from the skeleton and a compact island longer than
// bone_calculus_max_length_mm stay. With the rule off (0) the stone stays.
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

TEST(BoneIslands, ACompactDetachedStoneIsRemovedARibSegmentAndABorderPieceStay) {
  CtVolume ct = tissue_scene();
  box(ct, {10, 10, 10}, {90, 40, 50}, 700);  // the skeleton: 80 x 30 x 40 mm
  box(ct, {20, 55, 25}, {29, 64, 34}, 900);  // a stone: 9 mm cube (0.73 ml), 15 mm from it
  box(ct, {40, 70, 30}, {80, 75, 35}, 700);  // a rib segment: 40 x 5 x 5 mm (1 ml)
  box(ct, {60, 50, 0}, {69, 59, 9}, 700);    // a compact piece cut by the scan's first slice
  box(ct, {80, 44, 20}, {89, 53, 29}, 700);  // a compact bone 4 mm from the skeleton (a joint)
  const Index3 stone_lo = {20, 55, 25}, stone_hi = {29, 64, 34};
  const Index3 rib_lo = {40, 70, 30}, rib_hi = {80, 75, 35};
  const Index3 cut_lo = {60, 50, 0}, cut_hi = {69, 59, 9};
  SegmentationParams off;
  off.bone_calculus_max_length_mm = 0.0;
  const Mask without = bone_of(ct, off);
  const Mask with = bone_of(ct);
  EXPECT_EQ(count_in(without, stone_lo, stone_hi), 9 * 9 * 9) << "the stone is not bone: no test";
  EXPECT_EQ(count_in(with, stone_lo, stone_hi), 0);
  EXPECT_EQ(count_in(with, rib_lo, rib_hi), 40 * 5 * 5);
  EXPECT_EQ(count_in(with, cut_lo, cut_hi), 9 * 9 * 9);
  EXPECT_EQ(count_in(with, {80, 44, 20}, {89, 53, 29}), 9 * 9 * 9);
  EXPECT_EQ(count_in(with, {10, 10, 10}, {90, 40, 50}), 80 * 30 * 40);
  EXPECT_EQ(count_in(with, {0, 0, 0}, {100, 100, 60}),
            count_in(without, {0, 0, 0}, {100, 100, 60}) - 9 * 9 * 9);
  // A shorter maximum length (8 mm) spares the 9 mm stone: the length, not only the shape, counts.
  SegmentationParams short_max;
  short_max.bone_calculus_max_length_mm = 8.0;
  EXPECT_EQ(count_in(bone_of(ct, short_max), stone_lo, stone_hi), 9 * 9 * 9);
}

TEST(BoneIslands, OutOfRangeLengthIsRefused) {
  const CtVolume ct = tissue_scene();
  for (const double bad : {-1.0, 201.0}) {
    SegmentationParams p;
    p.bone_calculus_max_length_mm = bad;
    EXPECT_THROW(bone_of(ct, p), UsageError) << bad;
  }
}

}  // namespace
}  // namespace palp
