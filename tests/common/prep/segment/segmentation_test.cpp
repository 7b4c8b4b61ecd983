// Tests for body and bone segmentation (common/prep/segment/segmentation.cpp): small inline scenes
// for each rule, the torso phantom against its truth masks (Dice, table voxels, bone surface
// distance), and the real abdominal CT from ../shared/data when it is present.
#include "prep/segment/segmentation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <limits>
#include <vector>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "io/phantom.hpp"
#include "support/mask_metrics.hpp"

namespace palp {
namespace {

using testing::count;
using testing::count_and_not;
using testing::count_both;
using testing::dice;
using testing::mean_surface_distance;

// ---------------------------------------------------------------------------------------------
// Helpers

CtVolume scene(Index3 dims, double spacing_mm, std::int16_t fill = -1000) {
  Grid g;
  g.dims = dims;
  g.spacing = {spacing_mm, spacing_mm, spacing_mm};
  return CtVolume(g, fill, "test scene");
}

// Paints HU into the box [i0, i1) x [j0, j1) x [k0, k1).
void box(CtVolume& ct, Index3 lo, Index3 hi, std::int16_t hu) {
  for (std::int64_t k = lo[2]; k < hi[2]; ++k)
    for (std::int64_t j = lo[1]; j < hi[1]; ++j)
      for (std::int64_t i = lo[0]; i < hi[0]; ++i) ct.at(i, j, k) = hu;
}

// Paints HU into a cylinder along k (radius in voxels, slices [k0, k1)).
void cylinder(CtVolume& ct, double ci, double cj, double radius, std::int64_t k0, std::int64_t k1,
              std::int16_t hu) {
  for (std::int64_t k = k0; k < k1; ++k)
    for (std::int64_t j = 0; j < ct.grid.dims[1]; ++j)
      for (std::int64_t i = 0; i < ct.grid.dims[0]; ++i)
        if (std::hypot(i - ci, j - cj) <= radius) ct.at(i, j, k) = hu;
}

void ball(CtVolume& ct, Vec3 c, double radius, std::int16_t hu) {
  for (std::int64_t k = 0; k < ct.grid.dims[2]; ++k)
    for (std::int64_t j = 0; j < ct.grid.dims[1]; ++j)
      for (std::int64_t i = 0; i < ct.grid.dims[0]; ++i)
        if (std::hypot(i - c[0], j - c[1], k - c[2]) <= radius) ct.at(i, j, k) = hu;
}

// The body and bone of a scene with default parameters.
struct Segmented {
  Mask body, bone;
  SegmentationStats stats;
};

Segmented segment(const CtVolume& ct, const SegmentationParams& params = {}) {
  Segmented s;
  s.body = segment_body(ct, params, &s.stats);
  s.bone = segment_bone(ct, s.body, params, &s.stats);
  return s;
}

// ---------------------------------------------------------------------------------------------
// Orientation

TEST(PatientAxes, FollowTheWorldDirection) {
  Grid g;
  PatientAxes a = patient_axes(g);  // identity: the phantom convention
  EXPECT_EQ(a.slice, 2);
  EXPECT_EQ(a.posterior, 1);
  EXPECT_EQ(a.lateral, 0);
  EXPECT_TRUE(a.posterior_increasing);

  g.world.direction = {-1, 0, 0, 0, -1, 0, 0, 0, 1};  // a RAS NIfTI seen in LPS
  a = patient_axes(g);
  EXPECT_EQ(a.slice, 2);
  EXPECT_EQ(a.posterior, 1);
  EXPECT_FALSE(a.posterior_increasing);

  // Columns: i points posterior, j inferior, k left (a sagittal stack).
  g.world.direction = {0, 0, 1, 1, 0, 0, 0, -1, 0};
  a = patient_axes(g);
  EXPECT_EQ(a.slice, 1);
  EXPECT_EQ(a.posterior, 0);
  EXPECT_EQ(a.lateral, 2);
  EXPECT_TRUE(a.posterior_increasing);

  g.world.direction = {0, 0, 0, 0, 0, 0, 0, 0, 0};  // unusable: fall back to i, j, k
  a = patient_axes(g);
  EXPECT_EQ(a.slice, 2);
  EXPECT_EQ(a.posterior, 1);
}

// ---------------------------------------------------------------------------------------------
// Body rules on inline scenes (2 mm voxels; the table side is large j unless flipped)

// A soft-tissue block through every slice: 120 x 100 mm across, 120 mm wide FOV margins.
constexpr Index3 kSceneDims{120, 80, 30};
constexpr Index3 kTorsoLo{30, 10, 0}, kTorsoHi{90, 60, 30};

TEST(SegmentBody, FillsInternalAirThatReachesTheTopSlice) {
  CtVolume ct = scene(kSceneDims, 2.0);
  box(ct, kTorsoLo, kTorsoHi, 40);
  cylinder(ct, 60, 35, 10, 12, 30, -900);  // a "lung" running out through the top slice
  ball(ct, {45, 25, 5}, 4, -1000);         // bowel gas enclosed in 3D
  const Mask body = segment_body(ct, {});
  CtVolume expected = scene(kSceneDims, 2.0, 0);
  box(expected, kTorsoLo, kTorsoHi, 1);
  for (std::size_t n = 0; n < body.size(); ++n)
    ASSERT_EQ(body.data[n], expected.data[n]) << "voxel " << n;
}

class TableScene : public ::testing::TestWithParam<bool> {
 protected:
  // Flipped: a RAS-like grid whose posterior side is j = 0, the scene mirrored to match.
  bool flipped() const { return GetParam(); }
  std::int64_t row(std::int64_t j) const { return flipped() ? kSceneDims[1] - 1 - j : j; }
  void rows(CtVolume& ct, std::int64_t j0, std::int64_t j1, std::int64_t i0, std::int64_t i1,
            std::int16_t hu) const {
    const std::int64_t a = std::min(row(j0), row(j1 - 1)), b = std::max(row(j0), row(j1 - 1)) + 1;
    box(ct, {i0, a, 0}, {i1, b, kSceneDims[2]}, hu);
  }
  CtVolume make() const {
    CtVolume ct = scene(kSceneDims, 2.0);
    if (flipped()) ct.grid.world.direction = {-1, 0, 0, 0, -1, 0, 0, 0, 1};
    rows(ct, kTorsoLo[1], kTorsoHi[1], kTorsoLo[0], kTorsoHi[0], 40);
    return ct;
  }
  Mask torso(const CtVolume& ct) const {
    CtVolume t = scene(kSceneDims, 2.0, 0);
    t.grid = ct.grid;
    rows(t, kTorsoLo[1], kTorsoHi[1], kTorsoLo[0], kTorsoHi[0], 1);
    Mask m(ct.grid, 0);
    for (std::size_t n = 0; n < m.size(); ++n) m.data[n] = t.data[n] != 0;
    return m;
  }
};

TEST_P(TableScene, RemovesAThinWideBandBelowThePatient) {
  CtVolume ct = make();
  rows(ct, 66, 70, 0, kSceneDims[0], 300);  // carbon board across the whole width, 12 mm below
  SegmentationStats stats;
  const Mask body = segment_body(ct, {}, &stats);
  const Mask expected = torso(ct);
  EXPECT_EQ(count_and_not(body, expected), 0) << "table voxels in the body";
  EXPECT_EQ(count_and_not(expected, body), 0) << "patient voxels lost";
  EXPECT_EQ(stats.removed_non_patient_voxels, static_cast<std::uint64_t>(4 * 120 * 30));
}

TEST_P(TableScene, RemovesAPadPressedAgainstTheBackAndACableOnIt) {
  CtVolume ct = make();
  rows(ct, 60, 70, 5, 115, -100);           // gel pad touching the back, 20 mm
  rows(ct, 70, 74, 0, kSceneDims[0], 300);  // board
  rows(ct, 57, 60, 100, 103, 200);          // cable lying on the pad beside the patient
  const Mask body = segment_body(ct, {});
  const Mask expected = torso(ct);
  EXPECT_EQ(count_and_not(body, expected), 0) << "table voxels in the body";
  EXPECT_EQ(count_and_not(expected, body), 0) << "patient voxels lost";
}

TEST_P(TableScene, KeepsAPosteriorWallInFrontOfALung) {
  // A thin back wall with enclosed air in front of it is patient, not table.
  CtVolume ct = make();
  rows(ct, 20, 55, 40, 80, -850);  // lung: the wall behind it is 10 mm thick and 80 mm wide
  rows(ct, 66, 70, 0, kSceneDims[0], 300);
  const Mask body = segment_body(ct, {});
  const Mask expected = torso(ct);
  EXPECT_EQ(count_and_not(expected, body), 0);
  EXPECT_EQ(count_and_not(body, expected), 0);
}

INSTANTIATE_TEST_SUITE_P(BothPosteriorDirections, TableScene, ::testing::Values(false, true));

TEST(Segment, DoesNotDependOnHowTheAxesAreStored) {
  // A scene with a pad, a board, a lung and a bone ring, on an anisotropic grid.
  CtVolume ct = scene({120, 80, 20}, 2.0);
  ct.grid.spacing = {2.0, 2.0, 3.0};
  box(ct, kTorsoLo, {90, 60, 20}, 40);
  box(ct, {5, 60, 0}, {115, 70, 20}, -100);
  box(ct, {0, 70, 0}, {120, 74, 20}, 300);
  cylinder(ct, 45, 30, 8, 5, 20, -850);
  cylinder(ct, 70, 40, 7, 0, 20, 700);
  cylinder(ct, 70, 40, 4, 0, 20, 90);
  const Segmented direct = segment(ct);
  ASSERT_GT(count(direct.bone), 0);

  // The same voxels stored as P(a, b, c) = S(b, c, a): a runs along the slices, c posterior.
  const Index3 d = ct.grid.dims;
  CtVolume permuted = scene({d[2], d[0], d[1]}, 2.0);
  permuted.grid.spacing = {3.0, 2.0, 2.0};
  permuted.grid.world.direction = {0, 1, 0, 0, 0, 1, 1, 0, 0};
  for (std::int64_t k = 0; k < d[2]; ++k)
    for (std::int64_t j = 0; j < d[1]; ++j)
      for (std::int64_t i = 0; i < d[0]; ++i) permuted.at(k, i, j) = ct.at(i, j, k);
  const Segmented other = segment(permuted);
  std::int64_t body_differences = 0, bone_differences = 0;
  for (std::int64_t k = 0; k < d[2]; ++k)
    for (std::int64_t j = 0; j < d[1]; ++j)
      for (std::int64_t i = 0; i < d[0]; ++i) {
        body_differences += direct.body.at(i, j, k) != other.body.at(k, i, j);
        bone_differences += direct.bone.at(i, j, k) != other.bone.at(k, i, j);
      }
  EXPECT_EQ(body_differences, 0);
  EXPECT_EQ(bone_differences, 0);
  Mask torso(ct.grid, 0);
  for (std::int64_t k = 0; k < d[2]; ++k)
    for (std::int64_t j = kTorsoLo[1]; j < 60; ++j)
      for (std::int64_t i = kTorsoLo[0]; i < 90; ++i) torso.at(i, j, k) = 1;
  EXPECT_EQ(count_and_not(direct.body, torso), 0) << "pad or board in the body";
  EXPECT_EQ(count_and_not(torso, direct.body), 0) << "patient voxels lost";
}

TEST(SegmentBody, KeepsAnArmAndDropsSmallParts) {
  CtVolume ct = scene({150, 80, 30}, 2.0);
  box(ct, {30, 10, 0}, {90, 60, 30}, 40);    // torso
  box(ct, {95, 20, 0}, {125, 50, 30}, 40);   // arm, 10 mm away: 60 x 60 x 60 mm = 216 ml
  box(ct, {135, 5, 10}, {145, 15, 20}, 40);  // 8 ml of something else
  const Mask body = segment_body(ct, {});
  EXPECT_TRUE(body.at(110, 35, 15));
  EXPECT_FALSE(body.at(140, 10, 15));
  EXPECT_EQ(count(body), 60 * 50 * 30 + 30 * 30 * 30);
}

TEST(SegmentBody, KeepsThePatientEvenWhenSmallerThanTheMinimumPart) {
  // A 24 ml "patient" (e.g. a small phantom) and a 1 ml fragment, with the default 50 ml minimum:
  // the largest part is the patient and stays; the fragment still goes.
  CtVolume ct = scene({40, 40, 30}, 1.0);
  box(ct, {5, 5, 5}, {35, 35, 25}, 40);     // 30 x 30 x 20 mm = 18 ml
  box(ct, {36, 36, 10}, {39, 39, 13}, 40);  // 27 voxels, too thin for the 5 mm core anyway
  SegmentationParams params;
  ASSERT_GT(params.min_body_part_ml, 18.0);
  const Mask body = segment_body(ct, params);
  EXPECT_EQ(count(body), 30 * 30 * 20);
  EXPECT_FALSE(body.at(37, 37, 11));
}

TEST(SegmentBody, RejectsUnusableParameters) {
  const CtVolume ct = scene({10, 10, 10}, 2.0);
  SegmentationParams p;
  p.body_threshold_hu = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(segment_body(ct, p), UsageError);
  p = {};
  p.min_body_part_ml = -1.0;
  EXPECT_THROW(segment_body(ct, p), UsageError);
  p = {};
  p.bone_grow_hu = p.bone_seed_hu + 1.0;
  EXPECT_THROW(segment_bone(ct, Mask(ct.grid, 1), p), UsageError);
  const CtVolume other = scene({10, 10, 11}, 2.0);
  EXPECT_THROW(segment_bone(ct, Mask(other.grid, 1), {}), UsageError);
}

// ---------------------------------------------------------------------------------------------
// Bone rules (1 mm voxels, inside a soft-tissue body)

CtVolume bone_scene() {
  CtVolume ct = scene({100, 100, 60}, 1.0);
  box(ct, {5, 5, 0}, {95, 95, 60}, 40);
  return ct;
}

TEST(SegmentBone, FillsMarrowInsideACortexRing) {
  CtVolume ct = bone_scene();
  cylinder(ct, 30, 50, 12, 10, 50, 800);  // cortex with end plates
  cylinder(ct, 30, 50, 9, 12, 48, 80);    // fatty-red marrow below the growing threshold
  const Segmented s = segment(ct);
  std::int64_t missing = 0;
  for (std::int64_t k = 10; k < 50; ++k)
    for (std::int64_t j = 0; j < 100; ++j)
      for (std::int64_t i = 0; i < 100; ++i)
        missing += std::hypot(i - 30.0, j - 50.0) <= 12.0 && !s.bone.at(i, j, k);
  EXPECT_EQ(missing, 0);
}

TEST(SegmentBone, KeepsACanalOpen) {
  // Arches around a canal, one per vertebra, with the interlaminar spaces between them: the canal
  // is enclosed in axial slices only (a tube of bone closed along the whole scan is a long bone's
  // marrow cavity instead, and is filled: bone_marrow_test.cpp).
  CtVolume ct = bone_scene();
  for (std::int64_t k0 = 0; k0 < 60; k0 += 15) cylinder(ct, 50, 50, 14, k0, k0 + 11, 700);
  cylinder(ct, 50, 50, 8, 0, 60, 20);  // CSF
  const Segmented s = segment(ct);
  EXPECT_FALSE(s.bone.at(50, 50, 35));
  EXPECT_FALSE(s.bone.at(45, 50, 5));
  EXPECT_TRUE(s.bone.at(50, 38, 35));
}

TEST(SegmentBone, DoesNotGrowIntoAContrastBlobTouchingBone) {
  CtVolume ct = bone_scene();
  box(ct, {20, 40, 10}, {50, 60, 50}, 800);  // a bone block
  ball(ct, {61, 50, 30}, 11, 250);           // contrast-filled vessel touching its face
  const Segmented s = segment(ct);
  std::int64_t blob = 0, block = 0;
  for (std::int64_t k = 0; k < 60; ++k)
    for (std::int64_t j = 0; j < 100; ++j)
      for (std::int64_t i = 0; i < 100; ++i) {
        if (!s.bone.at(i, j, k)) continue;
        const bool in_block = i >= 20 && i < 50 && j >= 40 && j < 60 && k >= 10 && k < 50;
        block += in_block;
        blob += !in_block;
      }
  EXPECT_EQ(blob, 0);
  EXPECT_EQ(block, 30 * 20 * 40);
}

TEST(SegmentBone, ALeakIsDroppedWithItsContactEvenWithoutEdgeTrim) {
  // The blob's voxels against the block's face sit next to seeds, so they are not part of the
  // leak piece; they go with it (the edge trim is off here, so nothing else removes them).
  CtVolume ct = bone_scene();
  box(ct, {20, 40, 10}, {50, 60, 50}, 800);  // a bone block
  ball(ct, {61, 50, 30}, 11, 250);           // contrast-filled vessel touching its face at i = 50
  SegmentationParams no_trim;
  no_trim.bone_edge_fraction = 0.0;
  const Segmented s = segment(ct, no_trim);
  std::int64_t contact = 0;
  for (std::int64_t k = 0; k < 60; ++k)
    for (std::int64_t j = 0; j < 100; ++j) contact += ct.at(50, j, k) == 250;
  ASSERT_GT(contact, 0);  // the ball does touch the face
  EXPECT_EQ(count(s.bone), 30 * 20 * 40);
  for (std::int64_t k = 0; k < 60; ++k)
    for (std::int64_t j = 0; j < 100; ++j) EXPECT_FALSE(s.bone.at(50, j, k)) << j << " " << k;
  // A grown region that rests on the bone across a broad face is bone, contact and all.
  CtVolume broad = bone_scene();
  box(broad, {20, 40, 10}, {50, 60, 50}, 800);
  box(broad, {50, 40, 10}, {54, 60, 50}, 250);  // a 4-voxel layer of lower-HU bone on the face
  EXPECT_EQ(count(segment(broad, no_trim).bone), 34 * 20 * 40);
}

TEST(SegmentBone, LumensAreNotBoneNorAFlapInsideThem) {
  // A lumen (prep/vessel: not_bone) of seed-level contrast crossed by a flap of 600 HU that the
  // lumen's mask leaves out (a dissection's flap, a calcified septum, the heart's trabeculae), and
  // a bone block apart. The lumen's voxels are never bone; the flap, its surface all on the
  // lumen, goes with it; the block stays whole.
  CtVolume ct = bone_scene();
  box(ct, {20, 40, 10}, {40, 60, 50}, 800);  // a bone block
  box(ct, {60, 30, 10}, {90, 70, 50}, 400);  // a lumen
  box(ct, {60, 50, 10}, {90, 51, 50}, 600);  // the flap
  Mask lumen(ct.grid, 0, "lumen");
  for (std::int64_t k = 10; k < 50; ++k)
    for (std::int64_t j = 30; j < 70; ++j)
      for (std::int64_t i = 60; i < 90; ++i) lumen.at(i, j, k) = j != 50;
  const Mask body = segment_body(ct, {});
  const Mask bone = segment_bone(ct, body, {}, nullptr, &lumen);
  std::int64_t block = 0, flap = 0, elsewhere = 0;
  for (std::int64_t k = 0; k < 60; ++k)
    for (std::int64_t j = 0; j < 100; ++j)
      for (std::int64_t i = 0; i < 100; ++i) {
        if (!bone.at(i, j, k)) continue;
        const bool in_block = i >= 20 && i < 40 && j >= 40 && j < 60 && k >= 10 && k < 50;
        const bool in_flap = i >= 60 && i < 90 && j == 50 && k >= 10 && k < 50;
        (in_block ? block : in_flap ? flap : elsewhere) += 1;
      }
  EXPECT_EQ(block, 20 * 20 * 40);
  EXPECT_EQ(flap, 0);
  EXPECT_EQ(elsewhere, 0);
  // Without the lumen the contrast is bone (or the scene tests nothing).
  EXPECT_GT(count(segment_bone(ct, body, {})), 20 * 20 * 40 + 1000);
}

TEST(SegmentBone, ACalcifiedFlapBesideAVertebraIsNotJoinedToItByMarrow) {
  // A dissected aorta beside a vertebra: the lumen (a tube of 400 HU, radius 10 mm, in a 1 mm
  // wall) holds a calcified intimal ring of 1200 HU (radius 7-8.5 mm, off centre so that it meets
  // the wall on the vertebra's side; the lumen's mask leaves it out) and lies 2 mm (fat and wall)
  // from a vertebra (cortex ring, marrow below the growing level). Seen from the vertebra the
  // ring is a second cortex a few millimetres away: the marrow rules bracket the fat and wall
  // between them, the ring joins the skeleton, and the island rule run after them no longer sees
  // it (every voxel of the ring stays bone). Islands on a lumen go before the marrow rules: none.
  CtVolume ct = bone_scene();
  cylinder(ct, 30, 50, 12, 10, 50, 800);      // cortex with end plates
  cylinder(ct, 30, 50, 9, 12, 48, 80);        // marrow
  box(ct, {43, 38, 10}, {44, 62, 50}, -100);  // fat between vertebra and aorta
  cylinder(ct, 55, 50, 11, 10, 50, 40);       // the aortic wall
  cylinder(ct, 55, 50, 10, 10, 50, 400);      // the lumen
  Mask lumen(ct.grid, 0, "lumen");
  for (std::int64_t k = 10; k < 50; ++k)
    for (std::int64_t j = 0; j < 100; ++j)
      for (std::int64_t i = 0; i < 100; ++i) {
        if (std::hypot(i - 55.0, j - 50.0) > 10.0) continue;
        const double r = std::hypot(i - 53.5, j - 50.0);
        const bool ring = r >= 7.0 && r <= 8.5;
        if (ring) ct.at(i, j, k) = 1200;
        lumen.at(i, j, k) = !ring;
      }
  const Mask body = segment_body(ct, {});
  const Mask bone = segment_bone(ct, body, {}, nullptr, &lumen);
  std::int64_t ring = 0, ring_bone = 0, vertebra = 0, vertebra_bone = 0;
  for (std::int64_t k = 12; k < 48; ++k)
    for (std::int64_t j = 0; j < 100; ++j)
      for (std::int64_t i = 0; i < 100; ++i) {
        const double r = std::hypot(i - 53.5, j - 50.0);
        if (r >= 7.0 && r <= 8.5 && std::hypot(i - 55.0, j - 50.0) <= 10.0) {
          ++ring;
          ring_bone += bone.at(i, j, k);
        }
        if (std::hypot(i - 30.0, j - 50.0) <= 12.0) {
          ++vertebra;
          vertebra_bone += bone.at(i, j, k);
        }
      }
  EXPECT_EQ(ring_bone, 0) << "of " << ring;
  EXPECT_EQ(vertebra_bone, vertebra);
}

TEST(SegmentBone, MarrowBehindALumenRestingOnThinCortexIsBone) {
  // A vertebra (cortex ring with end plates, marrow below the growing level) whose cortex the
  // lumen resting on it replaces along an arc (a scan's blur: the aorta on a thin anterior
  // cortex). The lumen is not bone; the marrow behind it is, but for a notch of a few voxels at
  // the opening (at least 85 % of it, and less than half without the second marrow pass).
  CtVolume ct = bone_scene();
  cylinder(ct, 30, 50, 12, 10, 50, 800);  // cortex with end plates
  cylinder(ct, 30, 50, 9, 12, 48, 80);    // marrow
  Mask lumen(ct.grid, 0, "lumen");
  for (std::int64_t k = 5; k < 55; ++k)
    for (std::int64_t j = 0; j < 100; ++j)
      for (std::int64_t i = 0; i < 100; ++i) {
        const bool arc = i >= 39 && i <= 42 && std::abs(j - 50) <= 4 && k >= 12 && k < 48;
        const bool tube = std::hypot(i - 52.0, j - 50.0) <= 10.0;
        if (arc || tube) {
          ct.at(i, j, k) = 400;
          lumen.at(i, j, k) = 1;
        }
      }
  const Mask body = segment_body(ct, {});
  SegmentationParams one_pass;
  one_pass.bone_marrow_behind_lumens = false;
  for (const bool second_pass : {true, false}) {
    const Mask bone =
        segment_bone(ct, body, second_pass ? SegmentationParams{} : one_pass, nullptr, &lumen);
    std::int64_t marrow = 0, missing = 0, lumen_bone = 0;
    for (std::int64_t k = 12; k < 48; ++k)
      for (std::int64_t j = 0; j < 100; ++j)
        for (std::int64_t i = 0; i < 100; ++i) {
          if (lumen.at(i, j, k)) {
            lumen_bone += bone.at(i, j, k);
            continue;
          }
          if (std::hypot(i - 30.0, j - 50.0) > 8.0) continue;
          ++marrow;
          missing += !bone.at(i, j, k);
        }
    EXPECT_EQ(lumen_bone, 0);
    if (second_pass) {
      EXPECT_LE(missing * 100, marrow * 15) << "of " << marrow;
    } else {
      EXPECT_GT(missing * 2, marrow) << "the scene needs no second pass: no test";
    }
  }
}

TEST(SegmentBone, DropsSmallIslandsAndStaysInsideTheBody) {
  CtVolume ct = bone_scene();
  box(ct, {20, 20, 20}, {40, 40, 40}, 800);  // 8 ml of bone
  box(ct, {70, 70, 30}, {76, 76, 36}, 800);  // 0.2 ml calcification
  box(ct, {0, 0, 0}, {3, 100, 60}, 900);     // bright object outside the body (a table edge)
  const Segmented s = segment(ct);
  EXPECT_EQ(count(s.bone), 20 * 20 * 20);
  EXPECT_EQ(s.stats.bone_voxels, static_cast<std::uint64_t>(20 * 20 * 20));
  EXPECT_EQ(count_and_not(s.bone, s.body), 0);
}

// ---------------------------------------------------------------------------------------------
// The torso phantom against its truth

TEST(SegmentTorso, MatchesThePhantomTruth) {
  PhantomTruth truth;
  const CtVolume ct = make_phantom("torso", {}, &truth);
  const auto start = std::chrono::steady_clock::now();
  const Segmented s = segment(ct);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double body_dice = dice(s.body, truth.body);
  const double bone_dice = dice(s.bone, truth.bone);
  const double bone_surface_mm = mean_surface_distance(s.bone, truth.bone);
  std::cout << "torso: body Dice " << body_dice << ", bone Dice " << bone_dice
            << ", bone mean surface distance " << bone_surface_mm << " mm, segmentation " << seconds
            << " s\n";
  EXPECT_GE(body_dice, 0.99);
  EXPECT_EQ(count_both(s.body, truth.equipment), 0) << "table, pad or cable voxels in the body";
  EXPECT_GE(bone_dice, 0.9);
  EXPECT_LE(bone_surface_mm, ct.grid.min_spacing());
  EXPECT_EQ(count_both(s.bone, truth.equipment), 0);
  // The arm is kept and the lungs in the top slice are inside.
  std::int64_t top_truth = 0, top_found = 0;
  const std::int64_t top = ct.grid.dims[2] - 1;
  for (std::int64_t j = 0; j < ct.grid.dims[1]; ++j)
    for (std::int64_t i = 0; i < ct.grid.dims[0]; ++i) {
      if (!truth.body.at(i, j, top) || ct.at(i, j, top) > -700) continue;
      ++top_truth;
      top_found += s.body.at(i, j, top);
    }
  EXPECT_GT(top_truth, 1000);
  EXPECT_EQ(top_found, top_truth);
}

// ---------------------------------------------------------------------------------------------
// The real CT (no expert segmentation offline: checks of what must hold)

class RealCt : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::string path = std::string(PALP_SHARED_DATA_DIR) + "/ct_abdomen_3mm.nii.gz";
    if (!std::filesystem::exists(path)) return;
    ct_ = new CtVolume(read_ct(path));
    const auto start = std::chrono::steady_clock::now();
    segmented_ = new Segmented(segment(*ct_));
    seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  static void TearDownTestSuite() {
    delete segmented_;
    delete ct_;
    segmented_ = nullptr;
    ct_ = nullptr;
  }
  void SetUp() override {
    if (!ct_) GTEST_SKIP() << "ct_abdomen_3mm.nii.gz is not in " << PALP_SHARED_DATA_DIR;
  }

  // 6-connected regions of voxels satisfying `inside`, as labels (0 = none) and sizes.
  template <class Inside>
  static std::vector<std::int32_t> label(const CtVolume& ct, Inside inside,
                                         std::vector<std::int64_t>& sizes) {
    const Grid& g = ct.grid;
    std::vector<std::int32_t> labels(ct.size(), 0);
    sizes.assign(1, 0);
    std::vector<std::int64_t> stack;
    const std::int64_t steps[3] = {1, g.dims[0], g.dims[0] * g.dims[1]};
    for (std::size_t seed = 0; seed < ct.size(); ++seed) {
      if (labels[seed] || !inside(seed)) continue;
      const auto id = static_cast<std::int32_t>(sizes.size());
      sizes.push_back(0);
      labels[seed] = id;
      stack.push_back(static_cast<std::int64_t>(seed));
      while (!stack.empty()) {
        const std::int64_t n = stack.back();
        stack.pop_back();
        ++sizes[id];
        const std::int64_t c[3] = {n % g.dims[0], (n / g.dims[0]) % g.dims[1],
                                   n / (g.dims[0] * g.dims[1])};
        for (int a = 0; a < 3; ++a)
          for (int d : {-1, 1}) {
            if (c[a] + d < 0 || c[a] + d >= g.dims[a]) continue;
            const auto m = static_cast<std::size_t>(n + d * steps[a]);
            if (!labels[m] && inside(m))
              labels[m] = id, stack.push_back(static_cast<std::int64_t>(m));
          }
      }
    }
    return labels;
  }

  // A soft-tissue voxel near the middle of the volume.
  static std::size_t centre_voxel(const CtVolume& ct) {
    const Grid& g = ct.grid;
    for (std::int64_t d = 0; d < g.dims[0] / 2; ++d) {
      const std::size_t n = g.linear(g.dims[0] / 2 + d, g.dims[1] / 2, g.dims[2] / 2);
      if (ct.data[n] > -100 && ct.data[n] < 100) return n;
    }
    return g.linear(g.dims[0] / 2, g.dims[1] / 2, g.dims[2] / 2);
  }

  static CtVolume* ct_;
  static Segmented* segmented_;
  static double seconds_;
};
CtVolume* RealCt::ct_ = nullptr;
Segmented* RealCt::segmented_ = nullptr;
double RealCt::seconds_ = 0.0;

TEST_F(RealCt, OrientationComesFromTheFile) {
  const PatientAxes axes = patient_axes(ct_->grid);
  EXPECT_EQ(axes.slice, 2);
  EXPECT_EQ(axes.posterior, 1);
  EXPECT_FALSE(axes.posterior_increasing) << "RAS file: the back is at j = 0";
  const double voxel_ml = 0.027;
  std::cout << "real CT: body " << static_cast<double>(segmented_->stats.body_voxels) * voxel_ml
            << " ml, bone " << static_cast<double>(segmented_->stats.bone_voxels) * voxel_ml
            << " ml, table voxels " << segmented_->stats.table_voxels << ", removed "
            << segmented_->stats.removed_non_patient_voxels << ", " << seconds_ << " s\n";
}

TEST_F(RealCt, NoBodyVoxelInTheTable) {
  // The table: regions above -500 HU, apart from the patient, that lie wholly in the 12
  // posterior-most rows (36 mm) and are big.
  const CtVolume& ct = *ct_;
  const Grid& g = ct.grid;
  std::vector<std::int64_t> sizes;
  const auto labels = label(
      ct, [&](std::size_t n) { return ct.data[n] > -500; }, sizes);
  const std::int32_t patient = labels[centre_voxel(ct)];
  std::vector<std::uint8_t> posterior(sizes.size(), 1);
  for (std::size_t n = 0; n < ct.size(); ++n) {
    const std::int64_t j =
        static_cast<std::int64_t>(n / static_cast<std::size_t>(g.dims[0])) % g.dims[1];
    if (labels[n] && j >= 12) posterior[labels[n]] = 0;  // the back is at j = 0 in this file
  }
  std::int64_t table = 0, in_body = 0;
  for (std::size_t n = 0; n < ct.size(); ++n) {
    const std::int32_t id = labels[n];
    if (!id || id == patient || !posterior[id] || sizes[id] < 1000) continue;
    ++table;
    in_body += segmented_->body.data[n];
  }
  EXPECT_GT(table, 5000) << "the table must be found for this check to mean anything";
  EXPECT_EQ(in_body, 0);
}

TEST_F(RealCt, BodyHoldsAllSoftTissueConnectedToThePatient) {
  const CtVolume& ct = *ct_;
  std::vector<std::int64_t> sizes;
  const auto labels = label(
      ct, [&](std::size_t n) { return ct.data[n] >= -150 && ct.data[n] <= 250; }, sizes);
  const std::int32_t patient = labels[centre_voxel(ct)];
  ASSERT_NE(patient, 0);
  EXPECT_GT(sizes[patient], 500000);
  std::int64_t missing = 0;
  for (std::size_t n = 0; n < ct.size(); ++n)
    missing += labels[n] == patient && !segmented_->body.data[n];
  EXPECT_EQ(missing, 0);
}

TEST_F(RealCt, LungBasesInTheTopSliceAreInside) {
  const CtVolume& ct = *ct_;
  const Grid& g = ct.grid;
  std::int64_t lung = 0;
  for (std::int64_t j = 0; j < g.dims[1]; ++j)
    for (std::int64_t i = 0; i < g.dims[0]; ++i)
      lung += segmented_->body.at(i, j, g.dims[2] - 1) && ct.at(i, j, g.dims[2] - 1) < -700;
  EXPECT_GT(lung, 500);
}

TEST_F(RealCt, BoneIsPlausible) {
  const CtVolume& ct = *ct_;
  const Mask& bone = segmented_->bone;
  const double bone_ml = static_cast<double>(count(bone)) * 0.027;
  EXPECT_GT(bone_ml, 700.0);
  EXPECT_LT(bone_ml, 1800.0);
  EXPECT_EQ(count_and_not(bone, segmented_->body), 0);
  // Dense bone is found: voxels >= 600 HU in regions of at least 1 ml are bone.
  std::vector<std::int64_t> sizes;
  const auto labels = label(
      ct, [&](std::size_t n) { return ct.data[n] >= 600 && segmented_->body.data[n]; }, sizes);
  std::int64_t dense = 0, found = 0;
  double hu_sum = 0.0;
  for (std::size_t n = 0; n < ct.size(); ++n) {
    if (bone.data[n]) hu_sum += ct.data[n];
    if (!labels[n] || sizes[labels[n]] < 37) continue;
    ++dense;
    found += bone.data[n];
  }
  EXPECT_GT(dense, 1000);
  EXPECT_GE(static_cast<double>(found), 0.9 * static_cast<double>(dense));
  // Marrow is filled but soft tissue is not: the mean HU of the mask stays bone-like.
  EXPECT_GT(hu_sum / static_cast<double>(count(bone)), 200.0);
}

}  // namespace
}  // namespace palp
