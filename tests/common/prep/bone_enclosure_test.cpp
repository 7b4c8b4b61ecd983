// Marrow between cortices (common/prep/bone_enclosure.cpp), through segment_bone on tiny inline
// scenes at 1 mm: marrow behind foramina that open it in every slice plane is filled by the lines
// that bone brackets, the foramina and the tissue around the bone are not; tissue between two
// parallel plates (a disc, a joint space) is bracketed only by the lines that cross it and stays
// out; tissue beside a single plate stays out.
#include <gtest/gtest.h>

#include <cstdint>

#include "base/errors.hpp"
#include "prep/segmentation.hpp"
#include "support/tissue_scene.hpp"

namespace palp {
namespace {

using testing::bone_of;
using testing::box;
using testing::count_in;
using testing::tissue_scene;

// A bone 24 x 20 x 14 mm (cortex 2 mm, 700 HU) around fatty marrow (-30 HU), with a foramen of
// 4 x 4 mm through the middle of each of its six walls: every axial, coronal and sagittal plane
// through its centre leaves it through two foramina, so the slice-plane votes do not reach its
// middle.
void pierced_bone(CtVolume& ct) {
  box(ct, {38, 40, 20}, {62, 60, 34}, 700);
  box(ct, {40, 42, 22}, {60, 58, 32}, -30);
  box(ct, {38, 48, 25}, {62, 52, 29}, 40);  // foramina of the two walls across x
  box(ct, {48, 40, 25}, {52, 60, 29}, 40);  // across y
  box(ct, {48, 48, 20}, {52, 52, 34}, 40);  // across z
}

TEST(BoneEnclosure, MarrowBehindForaminaInEveryPlaneIsFilled) {
  CtVolume ct = tissue_scene();
  pierced_bone(ct);
  SegmentationParams off;
  off.bone_enclosure_directions = 0;
  const Mask votes_only = bone_of(ct, off);
  EXPECT_FALSE(votes_only.at(50, 50, 27)) << "the votes alone fill the middle: no test";
  const Mask bone = bone_of(ct);
  // The marrow (20 x 16 x 10) is filled, its middle whole; the foramina's mouths stay open a voxel
  // or two deep (there the line through the foramen and its neighbours leave the bone).
  const std::int64_t marrow = 20 * 16 * 10;
  EXPECT_EQ(count_in(bone, {44, 46, 24}, {56, 54, 30}), 12 * 8 * 6);
  EXPECT_GE(count_in(bone, {40, 42, 22}, {60, 58, 32}), marrow * 9 / 10);
  EXPECT_LT(count_in(votes_only, {40, 42, 22}, {60, 58, 32}),
            count_in(bone, {40, 42, 22}, {60, 58, 32}));
  EXPECT_EQ(count_in(bone, {38, 48, 25}, {40, 52, 29}), 0);
  EXPECT_EQ(count_in(bone, {48, 48, 20}, {52, 52, 22}), 0);
  // Nothing outside the bone.
  EXPECT_EQ(count_in(bone, {0, 0, 0}, {100, 100, 60}), count_in(bone, {38, 40, 20}, {62, 60, 34}));
}

TEST(BoneEnclosure, TissueBetweenParallelPlatesOrBesideOneStaysOut) {
  // Two plates 6 mm apart (a joint space): the 9 lines that cross the gap find bone on both
  // sides, the 4 in its plane none. And a single plate: one side only.
  CtVolume ct = tissue_scene();
  box(ct, {20, 20, 10}, {50, 24, 50}, 700);
  box(ct, {20, 30, 10}, {50, 34, 50}, 700);
  box(ct, {70, 20, 10}, {74, 80, 50}, 700);
  const Mask bone = bone_of(ct);
  EXPECT_EQ(count_in(bone, {20, 24, 10}, {50, 30, 50}), 0);
  EXPECT_EQ(count_in(bone, {0, 0, 0}, {100, 100, 60}), 2 * 30 * 4 * 40 + 4 * 60 * 40);
}

TEST(BoneEnclosure, RejectsUnusableParameters) {
  const CtVolume ct = tissue_scene();
  const Mask body = segment_body(ct, SegmentationParams{});
  for (const int lines : {-1, 14}) {
    SegmentationParams p;
    p.bone_enclosure_directions = lines;
    EXPECT_THROW(segment_bone(ct, body, p), UsageError);
  }
  for (const double radius : {-1.0, 101.0}) {
    SegmentationParams p;
    p.bone_enclosure_radius_mm = radius;
    EXPECT_THROW(segment_bone(ct, body, p), UsageError);
  }
}

}  // namespace
}  // namespace palp
