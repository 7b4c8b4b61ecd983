// Notches (common/prep/bone/bone_segmentation.cpp, fill_notches), through segment_bone on tiny
// inline scenes at 1 mm: after the edge trim, a body voxel outside the bone with bone on four or
// more of its six faces is filled until none is left. A partial-volume layer whose HU straddles the
// trim's level (so that the trim, voxel by voxel, cuts it into a checkerboard) is closed again; a
// pit, a one-voxel tunnel's mouths and a groove one voxel wide (zipped shut from a voxel of it the
// trim keeps) are filled; a groove two voxels wide and a gap two voxels high stay open. Each fails
// with bone_notch_faces 0 (the rule off) where it says so.
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

SegmentationParams rule_off() {
  SegmentationParams p;
  p.bone_notch_faces = 0;
  return p;
}

TEST(BoneNotches, APartialVolumeLayerTheTrimCutsIntoACheckerboardIsClosed) {
  // A bone block 30 x 30 x 20 mm at 700 HU under a layer one voxel thick whose voxels read 250 and
  // 200 HU in a checkerboard: with soft tissue (40 HU) above, the trim's level there is
  // 40 + 0.3 * (700 - 40) = 238 HU, so it keeps the 250s and drops the 200s. Each dropped voxel
  // then has bone on five faces (four kept neighbours and the block below), but the layer's two
  // corners that read 200 HU: bone on three faces (two neighbours and the block).
  CtVolume ct = tissue_scene();
  box(ct, {30, 30, 20}, {60, 60, 40}, 700);
  for (std::int64_t j = 32; j < 58; ++j)
    for (std::int64_t i = 32; i < 58; ++i) ct.at(i, j, 40) = (i + j) % 2 == 0 ? 250 : 200;
  const Index3 lo = {32, 32, 40}, hi = {58, 58, 41};
  const Mask off = bone_of(ct, rule_off());
  const Mask on = bone_of(ct);
  EXPECT_EQ(count_in(off, lo, hi), 26 * 26 / 2) << "the trim no longer cuts the layer: no test";
  EXPECT_EQ(count_in(on, lo, hi), 26 * 26 - 2);
  EXPECT_FALSE(on.at(57, 32, 40));
  EXPECT_FALSE(on.at(32, 57, 40));
  // Nothing else changes: the block is whole both ways and nothing is added above the layer.
  EXPECT_EQ(count_in(on, {30, 30, 20}, {60, 60, 40}), 30 * 30 * 20);
  EXPECT_EQ(count_in(on, {0, 0, 0}, {100, 100, 60}), 30 * 30 * 20 + 26 * 26 - 2);
  EXPECT_EQ(count_in(off, {0, 0, 0}, {100, 100, 60}), 30 * 30 * 20 + 26 * 26 / 2);
}

TEST(BoneNotches, PitsTunnelMouthsAndANarrowGrooveAreFilledAWideGrooveAndAGapStayOpen) {
  // A block 40 x 30 x 20 mm at 700 HU with, in soft tissue (40 HU): a pit one voxel wide and deep
  // in its top face (five bone faces), a tunnel one voxel across through it along x (its mouths
  // have four bone faces once the trim opens them), grooves one and two voxels wide, one deep,
  // along y in its top face (three bone faces and two), and beside it two plates with a gap two
  // voxels high between them (a disc or joint space the scan resolves: one bone face).
  CtVolume ct = tissue_scene();
  box(ct, {20, 30, 20}, {60, 60, 40}, 700);
  ct.at(30, 40, 39) = 40;                   // the pit
  box(ct, {20, 50, 30}, {60, 51, 31}, 40);  // the tunnel
  box(ct, {45, 30, 39}, {46, 60, 40}, 40);  // the narrow groove
  box(ct, {52, 30, 39}, {54, 60, 40}, 40);  // the wide groove
  box(ct, {66, 30, 20}, {80, 60, 26}, 700);
  box(ct, {66, 30, 28}, {80, 60, 34}, 700);  // the gap: z 26 and 27
  const Mask off = bone_of(ct, rule_off());
  const Mask on = bone_of(ct);
  EXPECT_FALSE(off.at(30, 40, 39)) << "the trim no longer opens the pit: no test";
  EXPECT_TRUE(on.at(30, 40, 39));
  EXPECT_FALSE(off.at(20, 50, 30)) << "the trim no longer opens the tunnel's mouth: no test";
  EXPECT_TRUE(on.at(20, 50, 30));
  EXPECT_TRUE(on.at(59, 50, 30));
  EXPECT_EQ(count_in(on, {20, 50, 30}, {60, 51, 31}), 40);
  // The narrow groove: the trim keeps a voxel of it (at its ends), and from there each next one
  // has a fourth bone face. The wide groove stays as the trim leaves it, the gap stays open.
  EXPECT_LT(count_in(off, {45, 30, 39}, {46, 60, 40}), 30) << "the trim keeps the groove: no test";
  EXPECT_EQ(count_in(on, {45, 30, 39}, {46, 60, 40}), 30);
  EXPECT_EQ(count_in(on, {52, 30, 39}, {54, 60, 40}), count_in(off, {52, 30, 39}, {54, 60, 40}));
  EXPECT_LT(count_in(on, {52, 30, 39}, {54, 60, 40}), 60 / 2);
  EXPECT_EQ(count_in(on, {66, 30, 26}, {80, 60, 28}), 0);
  // Nothing outside the block and the plates.
  EXPECT_EQ(count_in(on, {0, 0, 0}, {100, 100, 60}),
            count_in(on, {20, 30, 20}, {60, 60, 40}) + 2 * 14 * 30 * 6);
}

TEST(BoneNotches, RejectsFewerThanFourFaces) {
  const CtVolume ct = tissue_scene();
  const Mask body = segment_body(ct, SegmentationParams{});
  for (const int faces : {-1, 1, 2, 3, 7}) {
    SegmentationParams p;
    p.bone_notch_faces = faces;
    EXPECT_THROW(segment_bone(ct, body, p), UsageError) << faces;
  }
  for (const int faces : {0, 4, 5, 6}) {
    SegmentationParams p;
    p.bone_notch_faces = faces;
    EXPECT_NO_THROW(segment_bone(ct, body, p)) << faces;
  }
}

}  // namespace
}  // namespace palp
