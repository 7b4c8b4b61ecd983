// Skin clearance (common/prep/bone/bone_segmentation.cpp, clear_skin; bone_skin_clearance_mm): a
// sharp reconstruction kernel makes the skin overshoot at its edge with the air, and nothing within
// the clearance of the outside may seed or grow bone; bone beneath it, and bone the scan's own
// border cuts, is untouched. Through segment_bone on inline scenes at 1 mm
// (support/tissue_scene.hpp).
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

// The scene's body (x, y in [5, 95)) with its outer two voxels at `rim_hu` on all four sides and
// through every slice (the skin as a bone kernel shows it) and a rib-like bar at 700 HU, 4 x 6 mm
// in cross-section, at x = 8..11: one voxel of tissue beneath the rim, 4 mm from the outside.
CtVolume sharpened_skin_scene(std::int16_t rim_hu) {
  CtVolume ct = tissue_scene();
  box(ct, {5, 5, 0}, {95, 7, 60}, rim_hu);
  box(ct, {5, 93, 0}, {95, 95, 60}, rim_hu);
  box(ct, {5, 5, 0}, {7, 95, 60}, rim_hu);
  box(ct, {93, 5, 0}, {95, 95, 60}, rim_hu);
  box(ct, {8, 40, 10}, {12, 46, 50}, 700);
  return ct;
}

TEST(BoneSkinClearance, AnOvershootingSkinIsNotBoneWhatLiesBeneathAndAtTheScansEndIs) {
  CtVolume ct = sharpened_skin_scene(400);
  box(ct, {40, 40, 0}, {60, 60, 8}, 700);  // bone cut by the scan's first slice
  const Mask bone = bone_of(ct);
  // The rim (two voxels, within 2 mm of the outside) is not bone anywhere.
  EXPECT_EQ(count_in(bone, {5, 5, 0}, {95, 7, 60}), 0);
  EXPECT_EQ(count_in(bone, {5, 93, 0}, {95, 95, 60}), 0);
  EXPECT_EQ(count_in(bone, {5, 5, 0}, {7, 95, 60}), 0);
  EXPECT_EQ(count_in(bone, {93, 5, 0}, {95, 95, 60}), 0);
  // The bar one voxel beneath the rim and the block at the scan's end are whole, and nothing else
  // is bone.
  EXPECT_EQ(count_in(bone, {8, 40, 10}, {12, 46, 50}), 4 * 6 * 40);
  EXPECT_EQ(count_in(bone, {40, 40, 0}, {60, 60, 8}), 20 * 20 * 8);
  EXPECT_EQ(count_in(bone, {0, 0, 0}, {100, 100, 60}), 4 * 6 * 40 + 20 * 20 * 8);
}

TEST(BoneSkinClearance, WithoutItTheOvershootingSkinIsBone) {
  SegmentationParams off;
  off.bone_skin_clearance_mm = 0.0;
  const Mask bone = bone_of(sharpened_skin_scene(400), off);
  EXPECT_GT(count_in(bone, {5, 5, 0}, {95, 7, 60}), 90 * 2 * 60 / 2);
  // A skin that does not overshoot (partial volume toward air) never was bone either way.
  EXPECT_EQ(count_in(bone_of(sharpened_skin_scene(-300), off), {5, 5, 0}, {95, 7, 60}), 0);
}

TEST(BoneSkinClearance, IsCheckedAsAParameter) {
  SegmentationParams p;
  p.bone_skin_clearance_mm = -1.0;
  const CtVolume ct = tissue_scene();
  EXPECT_THROW(bone_of(ct, p), UsageError);
  p.bone_skin_clearance_mm = 25.0;
  EXPECT_THROW(bone_of(ct, p), UsageError);
}

}  // namespace
}  // namespace palp
