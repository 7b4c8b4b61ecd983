// Marrow by votes of the three orthogonal slice planes (common/prep/bone/bone_marrow.cpp), through
// segment_bone on tiny inline scenes at 1 mm: marrow enclosed in every plane is filled, a canal
// enclosed only in axial slices stays open, a long bone the scan cuts at both ends keeps its
// marrow, and a disc two slices high between two vertebrae is not bridged.
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

// A cylinder along k of `radius` voxels around (ci, cj), slices [k0, k1).
void cylinder(CtVolume& ct, double ci, double cj, double radius, std::int64_t k0, std::int64_t k1,
              std::int16_t hu) {
  for (std::int64_t k = k0; k < k1; ++k)
    for (std::int64_t j = 0; j < 100; ++j)
      for (std::int64_t i = 0; i < 100; ++i)
        if ((i - ci) * (i - ci) + (j - cj) * (j - cj) <= radius * radius) ct.at(i, j, k) = hu;
}

// A vertebral body: a cortex shell 2 voxels thick around fatty marrow at -30 HU (below every
// growing level), in slices [k0, k0 + 16).
void vertebral_body(CtVolume& ct, std::int64_t k0) {
  box(ct, {30, 20, k0}, {70, 50, k0 + 16}, 700);
  box(ct, {32, 22, k0 + 2}, {68, 48, k0 + 14}, -30);
}

TEST(BoneMarrow, MarrowEnclosedInEveryPlaneIsFilled) {
  CtVolume ct = tissue_scene();
  vertebral_body(ct, 20);
  const Mask bone = bone_of(ct);
  EXPECT_EQ(count_in(bone, {32, 22, 22}, {68, 48, 34}), 36 * 26 * 12);  // all the marrow
  EXPECT_EQ(count_in(bone, {0, 0, 0}, {100, 100, 60}), 40 * 30 * 16);   // and nothing else
}

TEST(BoneMarrow, ACanalBehindFilledBodiesStaysOpen) {
  // Three vertebrae: bodies with marrow, arches around a canal of CSF, interlaminar spaces and
  // discs (soft tissue) between them.
  CtVolume ct = tissue_scene();
  for (const std::int64_t k0 : {2, 22, 42}) {
    vertebral_body(ct, k0);
    cylinder(ct, 50, 62, 12, k0 + 2, k0 + 14, 700);  // arch
  }
  cylinder(ct, 50, 62, 7, 0, 60, 10);  // the canal runs through every slice
  const Mask bone = bone_of(ct);
  EXPECT_EQ(count_in(bone, {32, 22, 24}, {68, 48, 34}), 36 * 26 * 10);  // the middle body's marrow
  EXPECT_EQ(count_in(bone, {46, 58, 0}, {55, 67, 60}), 0);              // the canal
  EXPECT_EQ(count_in(bone, {30, 20, 18}, {70, 50, 22}), 0);             // a disc
  // One vote (the axial plane alone) fills the canal inside the arches: the rule is what keeps it.
  SegmentationParams one;
  one.bone_marrow_votes = 1;
  EXPECT_EQ(count_in(bone_of(ct, one), {46, 58, 26}, {55, 67, 34}), 9 * 9 * 8);
}

TEST(BoneMarrow, ALongBoneTheScanCutsAtBothEndsKeepsItsMarrow) {
  // An arm's long bone beside the torso runs through the whole scan: its marrow cavity reaches the
  // first and last slices, which do not open it. Slices 4 mm apart: in a coronal plane the cavity
  // (15 x 240 mm) is larger than any axial hole may be; only its width is bounded there.
  CtVolume ct = tissue_scene();
  ct.grid.spacing[2] = 4.0;
  ASSERT_GT(15.0 * 240.0, SegmentationParams{}.bone_max_hole_mm2);
  cylinder(ct, 50, 50, 10, 0, 60, 800);
  cylinder(ct, 50, 50, 7, 0, 60, 0);  // fatty marrow
  const Mask bone = bone_of(ct);
  EXPECT_TRUE(bone.at(50, 50, 0));
  EXPECT_TRUE(bone.at(50, 50, 30));
  EXPECT_TRUE(bone.at(50, 50, 59));
  EXPECT_EQ(count_in(bone, {43, 43, 0}, {58, 58, 60}),
            count_in(bone, {43, 43, 0}, {58, 58, 1}) * 60);
}

TEST(BoneMarrow, ADiscTwoSlicesHighIsNotBridged) {
  // Two solid vertebral bodies 2 slices apart: a 3x3 closing across slices would bridge the disc
  // in the coronal and sagittal planes (two votes); their closing runs along the slices only.
  CtVolume ct = tissue_scene();
  box(ct, {30, 20, 10}, {70, 50, 29}, 400);
  box(ct, {30, 20, 31}, {70, 50, 50}, 400);
  box(ct, {30, 20, 29}, {70, 50, 31}, 90);  // the disc
  const Mask bone = bone_of(ct);
  EXPECT_EQ(count_in(bone, {30, 20, 29}, {70, 50, 31}), 0);
  EXPECT_EQ(count_in(bone, {0, 0, 0}, {100, 100, 60}), 40 * 30 * 38);
}

TEST(BoneMarrow, RejectsAVoteCountOutsideOneToThree) {
  const CtVolume ct = tissue_scene();
  const Mask body = segment_body(ct, SegmentationParams{});
  for (const int votes : {0, 4}) {
    SegmentationParams p;
    p.bone_marrow_votes = votes;
    EXPECT_THROW(segment_bone(ct, body, p), UsageError);
  }
}

}  // namespace
}  // namespace palp
