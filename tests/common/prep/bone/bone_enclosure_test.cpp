// Marrow between cortices (common/prep/bone/bone_enclosure.cpp), through segment_bone on tiny
// inline scenes at 1 mm: marrow behind foramina that open it in every slice plane is filled by the
// lines that bone brackets, the foramina and the tissue around the bone are not; tissue between two
// parallel plates (a disc, a joint space) is bracketed only by the lines that cross it and stays
// out; tissue beside a single plate stays out; a plate of marrow too thick for the radius is
// filled by the plate rule, a canal inside arches beside it is not.
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

// A ring of bone (arches) around a canal of CSF, in slices [k0, k0 + 12): centre (72, 50),
// radii 7 and 12 voxels.
void arch(CtVolume& ct, std::int64_t k0) {
  for (std::int64_t k = k0; k < k0 + 12; ++k)
    for (std::int64_t j = 0; j < 100; ++j)
      for (std::int64_t i = 0; i < 100; ++i) {
        const std::int64_t r2 = (i - 72) * (i - 72) + (j - 50) * (j - 50);
        if (r2 <= 12 * 12 && r2 > 7 * 7) ct.at(i, j, k) = 700;
      }
}

TEST(BoneEnclosure, APlateIsFilledWithinThePlateRadiusACanalIsNot) {
  // A plate: marrow 20 x 16 x 20 mm (x, y, z) in a 2 mm cortex. Its middle lies 8 mm from the
  // faces across y, 10 mm from the others and 14 mm along the diagonals that do not cross y:
  // within 12 mm bone brackets it along the 3 axes only, within 20 mm along all 13 lines, the
  // one along the body axis (z) included. Beside it, arches 12 mm high with 8 mm interlaminar
  // spaces around a canal through the whole scan: within 20 mm their tilted lines bracket the
  // canal, the line along the axis does not. The slice-plane holes and the 3-D cavity fill are off
  // (they would fill the closed plate), so the enclosure acts alone.
  CtVolume ct = tissue_scene();
  box(ct, {20, 20, 18}, {44, 40, 42}, 700);
  box(ct, {22, 22, 20}, {42, 38, 40}, -30);
  for (const std::int64_t k0 : {2, 22, 42}) arch(ct, k0);
  SegmentationParams p;
  p.bone_max_hole_mm2 = 0;
  p.bone_max_cavity_ml = 0;
  // The arches stand alone here, 8 mm apart with no bodies, as no vertebra does; compact and
  // detached, the calculus rule (bone_islands.hpp) would remove them: off.
  p.bone_calculus_max_length_mm = 0;
  SegmentationParams no_plate = p;
  no_plate.bone_plate_radius_mm = 0;
  SegmentationParams wide = no_plate;  // the 12 mm rule at 20 mm: no axis line needed
  wide.bone_enclosure_radius_mm = 20;
  const Mask bone = bone_of(ct, p), near_only = bone_of(ct, no_plate),
             wide_only = bone_of(ct, wide);
  const std::int64_t marrow = 20 * 16 * 20;
  const Index3 lo = {22, 22, 20}, hi = {42, 38, 40};
  const Index3 canal_lo = {68, 46, 0}, canal_hi = {77, 55, 60};  // the canal's core, 9 x 9
  // The 12 mm rule alone fills none of the marrow: no voxel of it has both x faces, both z faces
  // and the diagonals between them within 12 mm.
  EXPECT_EQ(count_in(near_only, lo, hi), 0);
  // The plate rule fills its core whole (4 mm and more from the x and z faces, 2 mm from the y
  // faces) and most of the rest; a voxel next to a face misses the lines across to the far face.
  EXPECT_EQ(count_in(bone, {26, 24, 24}, {38, 36, 36}), 12 * 12 * 12);
  const std::int64_t filled = count_in(bone, lo, hi);
  EXPECT_GE(filled, marrow * 85 / 100);
  // The canal stays open; a 20 mm radius without the axis line fills it.
  EXPECT_EQ(count_in(bone, canal_lo, canal_hi), 0);
  EXPECT_GT(count_in(wide_only, canal_lo, canal_hi), 0) << "the canal test does not bite";
  // Nothing but the cortex, the filled marrow and the arches.
  const std::int64_t cortex = 24 * 20 * 24 - marrow;
  EXPECT_EQ(count_in(bone, {20, 20, 18}, {44, 40, 42}), cortex + filled);
  EXPECT_EQ(count_in(bone, {0, 0, 0}, {100, 100, 60}),
            cortex + filled + count_in(bone, {60, 38, 0}, {85, 63, 60}));
  EXPECT_EQ(count_in(bone, {60, 38, 0}, {85, 63, 60}),
            count_in(near_only, {60, 38, 0}, {85, 63, 60}));
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
    SegmentationParams plate;
    plate.bone_plate_radius_mm = radius;
    EXPECT_THROW(segment_bone(ct, body, plate), UsageError);
  }
}

}  // namespace
}  // namespace palp
