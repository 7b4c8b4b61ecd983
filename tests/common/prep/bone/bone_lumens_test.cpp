// Contrast-filled lumens resting on bone (common/prep/bone/bone_lumens.cpp), through segment_bone:
// a vessel bright enough to seed (arterial phase, angiography: 350-500 HU) pressed against a bone
// block at 1 mm and at 3 mm voxels, and the torso phantom's aorta raised to that brightness on
// its default grid and on a coarse one, is not bone while the bone stays whole; a dim rib, a bone
// with a dim cortex around marrow and a thick bone of seed-level HU enclosed by cortex stay.
// With the rule off (bone_lumen_radius_mm 0, the pipeline before it) each vessel is bone. A
// filled lumen apart from the skeleton (remove_lumen_islands) goes whole, in a small scene and as
// the torso phantom's aorta moved away from the spine; a thick bone island with its cortex stays.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "base/errors.hpp"
#include "io/phantom.hpp"
#include "prep/segment/segmentation.hpp"
#include "support/tissue_scene.hpp"

namespace palp {
namespace {

using testing::bone_of;
using testing::box;
using testing::count_in;

SegmentationParams rule_off() {
  SegmentationParams p;
  p.bone_lumen_radius_mm = 0.0;
  return p;
}

// Soft tissue (40 HU) on a dims grid of `mm` voxels, `margin` voxels of air around it in i, j.
CtVolume tissue(Index3 dims, double mm, std::int64_t margin) {
  Grid g;
  g.dims = dims;
  g.spacing = {mm, mm, mm};
  CtVolume ct(g, -1000, "test scene");
  box(ct, {margin, margin, 0}, {dims[0] - margin, dims[1] - margin, dims[2]}, 40);
  return ct;
}

// A tube along k of radius r voxels around (ci, cj), every slice.
void tube(CtVolume& ct, double ci, double cj, double r, std::int16_t hu) {
  for (std::int64_t k = 0; k < ct.grid.dims[2]; ++k)
    for (std::int64_t j = 0; j < ct.grid.dims[1]; ++j)
      for (std::int64_t i = 0; i < ct.grid.dims[0]; ++i)
        if (std::hypot(i - ci, j - cj) <= r) ct.at(i, j, k) = hu;
}

// Bone voxels among the voxels of `ct` at exactly `hu`.
std::int64_t bone_at(const CtVolume& ct, const Mask& bone, std::int16_t hu) {
  std::int64_t n = 0;
  for (std::size_t v = 0; v < ct.data.size(); ++v) n += ct.data[v] == hu && bone.data[v];
  return n;
}

std::int64_t count_all(const Mask& m) {
  std::int64_t n = 0;
  for (auto v : m.data) n += v != 0;
  return n;
}

TEST(BoneLumens, AVesselPressedOnBoneAt1mmIsNotBone) {
  for (std::int16_t hu : {350, 420, 500}) {
    CtVolume ct = testing::tissue_scene();
    tube(ct, 58, 50, 10, hu);                  // a 20 mm vessel along the whole scan...
    box(ct, {20, 40, 10}, {50, 60, 50}, 800);  // ...pressed 2 mm into a bone block's face
    EXPECT_GT(bone_at(ct, bone_of(ct, rule_off()), hu), 1000) << hu << " HU: no test";
    const Mask bone = bone_of(ct);
    EXPECT_EQ(bone_at(ct, bone, hu), 0) << hu << " HU";
    EXPECT_EQ(count_in(bone, {20, 40, 10}, {50, 60, 50}), 30 * 20 * 40) << hu << " HU";
    EXPECT_EQ(count_all(bone), 30 * 20 * 40) << hu << " HU";
  }
}

TEST(BoneLumens, AVesselPressedOnBoneAt3mmIsNotBone) {
  // 3 mm voxels: a 24 mm vessel pressed one voxel into a 36 x 36 x 48 mm block, with voxels of
  // partial volume (a quarter bone: their centres lie in the vessel) along the contact.
  for (std::int16_t hu : {350, 420, 500}) {
    CtVolume ct = tissue({40, 40, 24}, 3.0, 2);
    tube(ct, 23, 20, 4, hu);
    box(ct, {8, 14, 4}, {20, 26, 20}, 800);
    for (std::int64_t k = 4; k < 20; ++k)
      for (std::int64_t j = 18; j < 23; ++j)
        ct.at(20, j, k) = static_cast<std::int16_t>(hu + (800 - hu) / 4);
    EXPECT_GT(bone_at(ct, bone_of(ct, rule_off()), hu), 100) << hu << " HU: no test";
    const Mask bone = bone_of(ct);
    EXPECT_EQ(bone_at(ct, bone, hu), 0) << hu << " HU";
    EXPECT_EQ(count_in(bone, {8, 14, 4}, {20, 26, 20}), 12 * 12 * 16) << hu << " HU";
    EXPECT_EQ(count_all(bone), 12 * 12 * 16) << hu << " HU";
  }
}

TEST(BoneLumens, ADimRibADimCortexAroundMarrowAndDenseEnclosedBoneStay) {
  // 3 mm voxels, every piece below the cortex level (700 HU) joined to a bright block: a rib two
  // voxels across at 450 HU (partial volume), a bone with a 500 HU cortex around 200 HU marrow,
  // and a thick 450 HU bone inside an 800 HU cortex.
  CtVolume ct = tissue({48, 48, 24}, 3.0, 2);
  box(ct, {20, 20, 2}, {28, 28, 22}, 800);   // the bright block
  box(ct, {28, 22, 10}, {44, 24, 12}, 450);  // the rib: 48 mm long, 6 x 6 mm
  box(ct, {8, 8, 4}, {20, 20, 20}, 500);     // a dim cortex (36 x 36 x 48 mm) on the block...
  box(ct, {9, 9, 5}, {19, 19, 19}, 200);     // ...around marrow
  box(ct, {28, 28, 4}, {40, 40, 20}, 800);   // a cortex on the block...
  box(ct, {29, 29, 5}, {39, 39, 19}, 450);   // ...around dense bone
  const Mask bone = bone_of(ct);
  EXPECT_EQ(count_in(bone, {28, 22, 10}, {44, 24, 12}), 16 * 2 * 2);
  EXPECT_EQ(count_in(bone, {8, 8, 4}, {20, 20, 20}), 12 * 12 * 16);
  EXPECT_EQ(count_in(bone, {28, 28, 4}, {40, 40, 20}), 12 * 12 * 16);
  EXPECT_EQ(count_all(bone), count_all(bone_of(ct, rule_off())));
}

TEST(BoneLumens, AFilledLumenApartFromTheSkeletonIsNotBoneAThickBoneIslandStays) {
  // 3 mm voxels: the skeleton (a bright block, the largest island); apart from it a filled lumen
  // 30 x 30 x 36 mm (bowel with oral contrast, 350 or 600 HU, below the cortex level of 700 HU,
  // inside a 250 HU partial-volume rim), a bone island as thick (an 800 HU cortex around 250 HU
  // cancellous bone: a femoral head apart from its socket), a thin uniform rib, and a thick
  // uniform bone 6 mm from the skeleton (across a joint space). Only the lumen goes.
  for (const std::int16_t fill : {350, 600}) {
    CtVolume ct = tissue({48, 48, 24}, 3.0, 2);
    box(ct, {4, 4, 2}, {16, 44, 22}, 800);    // the skeleton
    box(ct, {22, 4, 4}, {32, 14, 16}, 250);   // the lumen's rim...
    box(ct, {23, 5, 5}, {31, 13, 15}, fill);  // ...and its content
    box(ct, {22, 22, 4}, {34, 34, 16}, 800);  // a cortex...
    box(ct, {23, 23, 5}, {33, 33, 15}, 250);  // ...around cancellous bone
    box(ct, {38, 6, 10}, {40, 42, 12}, 450);  // a rib: 108 mm long, 6 x 6 mm
    box(ct, {18, 35, 4}, {28, 43, 16}, 400);  // a bone across a joint space from the skeleton
    const Mask before = bone_of(ct, rule_off());
    const std::int64_t lumen_before = count_in(before, {22, 4, 4}, {32, 14, 16});
    EXPECT_GT(lumen_before, 500) << fill << " HU: no test";
    const Mask bone = bone_of(ct);
    EXPECT_EQ(count_in(bone, {22, 4, 4}, {32, 14, 16}), 0) << fill << " HU";
    EXPECT_EQ(count_in(bone, {4, 4, 2}, {16, 44, 22}), 12 * 40 * 20) << fill << " HU";
    EXPECT_EQ(count_in(bone, {22, 22, 4}, {34, 34, 16}), 12 * 12 * 12) << fill << " HU";
    EXPECT_EQ(count_in(bone, {38, 6, 10}, {40, 42, 12}), 2 * 36 * 2) << fill << " HU";
    EXPECT_EQ(count_in(bone, {18, 35, 4}, {28, 43, 16}), 10 * 8 * 12) << fill << " HU";
    // Nothing else changes (the marrow rules bridge the 3-6 mm gaps either way).
    EXPECT_EQ(count_all(bone), count_all(before) - lumen_before) << fill << " HU";
  }
}

TEST(BoneLumens, ParametersAreChecked) {
  const CtVolume ct = testing::tissue_scene();
  const Mask body(ct.grid, 1);
  SegmentationParams p;
  p.bone_lumen_max_contact = 1.5;
  EXPECT_THROW(segment_bone(ct, body, p), UsageError);
  p = {};
  p.bone_lumen_radius_mm = -1.0;
  EXPECT_THROW(segment_bone(ct, body, p), UsageError);
  p = {};
  p.bone_lumen_cortex_margin_hu = -10.0;
  EXPECT_THROW(segment_bone(ct, body, p), UsageError);
}

// The torso phantom with its aorta (250 HU, not bone) raised to `hu`: its voxels of 235-265 HU
// that are body but not bone, and the partial volume around them in proportion. `lumen`: those
// of them whose centre lies a voxel or more inside the aorta (common/io/phantom.cpp: a cylinder
// of 12 mm radius at x = 30 mm, y = -0.5 mm in the anatomy frame, which these grids do not
// scale; the vertebrae's cortex overlaps it by 2.5 mm).
struct RaisedAorta {
  CtVolume ct;
  PhantomTruth truth;
  Mask lumen;
  Mask strip;  // voxels whose centre lies within two voxels outside the aorta, or inside it
};

RaisedAorta raised_aorta(Index3 dims, Vec3 spacing, std::int16_t hu) {
  RaisedAorta r;
  PhantomOptions o;
  o.dims = dims;
  o.spacing = spacing;
  r.ct = make_phantom("torso", o, &r.truth);
  const Grid& g = r.ct.grid;
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  // The anatomy frame as the phantom places it: centred, the pad's top (y = 85 mm) snapped
  // halfway between voxel rows.
  const double cx = 0.5 * static_cast<double>(nx) * spacing[0];
  double cy = 0.5 * static_cast<double>(ny) * spacing[1];
  const double pad = cy + 85.0;
  cy += (std::round(pad / spacing[1] - 0.5) + 0.5) * spacing[1] - pad;
  const double reach = 12.0 - std::max(spacing[0], spacing[1]);
  const double strip = 12.0 + 2.0 * std::max(spacing[0], spacing[1]);
  r.lumen = Mask(g, 0);
  r.strip = Mask(g, 0);
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        const double d = std::hypot(static_cast<double>(i) * spacing[0] - cx - 30.0,
                                    static_cast<double>(j) * spacing[1] - cy + 0.5);
        r.lumen.at(i, j, k) = d <= reach;
        r.strip.at(i, j, k) = d <= strip;
      }
  Mask aorta(g, 0);
  for (std::size_t n = 0; n < r.ct.data.size(); ++n)
    aorta.data[n] =
        r.truth.body.data[n] && !r.truth.bone.data[n] && r.ct.data[n] >= 235 && r.ct.data[n] <= 265;
  std::vector<std::int16_t> out = r.ct.data;
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx; ++i) {
        const std::size_t n = g.linear(i, j, k);
        const int v = r.ct.data[n];
        if (aorta.data[n]) {
          out[n] = static_cast<std::int16_t>(v - 250 + hu);
          continue;
        }
        bool rim = false;
        for (std::int64_t dk = -1; dk <= 1; ++dk)
          for (std::int64_t dj = -1; dj <= 1; ++dj)
            for (std::int64_t di = -1; di <= 1; ++di) {
              const std::int64_t a = i + di, b = j + dj, c = k + dk;
              if (a >= 0 && a < nx && b >= 0 && b < ny && c >= 0 && c < nz)
                rim = rim || aorta.at(a, b, c);
            }
        if (!rim || v <= 40 || v >= 235) continue;  // blends with brighter tissue: bone's
        const double share = (v - 40.0) / (250.0 - 40.0);
        out[n] = static_cast<std::int16_t>(std::lround(v + share * (hu - 250)));
      }
  r.ct.data = out;
  for (std::size_t n = 0; n < r.ct.data.size(); ++n) r.lumen.data[n] &= aorta.data[n];
  return r;
}

struct Scored {
  std::int64_t aorta_bone = 0;  // raised voxels segmented as bone
  std::int64_t missed = 0;      // true bone voxels not segmented, beyond the strip
  std::int64_t missed_in_strip = 0;
};

Scored score(const RaisedAorta& r, const SegmentationParams& p) {
  const Mask bone = bone_of(r.ct, p);
  Scored s;
  for (std::size_t n = 0; n < bone.data.size(); ++n) {
    s.aorta_bone += r.lumen.data[n] && bone.data[n];
    const bool missed = r.truth.bone.data[n] && !bone.data[n];
    (r.strip.data[n] ? s.missed_in_strip : s.missed) += missed;
  }
  return s;
}

// `left`: lumen voxels that may stay bone; `dent`: true bone voxels per slice that may go beyond
// those missed at 250 HU, all within the strip but for `dent_beyond` per slice.
void check_phantom(Index3 dims, Vec3 spacing, std::int64_t left, std::int64_t dent,
                   std::int64_t dent_beyond) {
  const Scored portal = score(raised_aorta(dims, spacing, 250), {});
  for (std::int16_t hu : {350, 450}) {
    const RaisedAorta r = raised_aorta(dims, spacing, hu);
    ASSERT_GT(count_all(r.lumen), 1000);
    EXPECT_GT(score(r, rule_off()).aorta_bone, count_all(r.lumen) / 2) << hu << " HU: no test";
    const Scored s = score(r, {});
    std::printf(
        "%d HU: lumen voxels bone %lld of %lld; true bone missed %lld beyond the strip "
        "(%lld at 250 HU), %lld in it (%lld)\n",
        hu, static_cast<long long>(s.aorta_bone), static_cast<long long>(count_all(r.lumen)),
        static_cast<long long>(s.missed), static_cast<long long>(portal.missed),
        static_cast<long long>(s.missed_in_strip), static_cast<long long>(portal.missed_in_strip));
    EXPECT_LE(s.aorta_bone, left) << hu << " HU";
    // The bone stays as whole as with the aorta at portal-venous brightness, but for voxels of
    // the vertebrae's front under the aorta: blends of cortex and lumen (the phantom keeps those
    // at the portal lumen's HU, so they read as more lumen than they are), which the lumen's
    // edge and the edge trim take.
    EXPECT_LE(s.missed, portal.missed + dent_beyond * dims[2]) << hu << " HU";
    EXPECT_LE(s.missed + s.missed_in_strip, portal.missed + portal.missed_in_strip + dent * dims[2])
        << hu << " HU";
  }
}

TEST(BoneLumens, TheTorsoPhantomsArterialAortaIsNotBone) {
  check_phantom({384, 256, 96}, {1.25, 1.25, 2.0}, 0, 2, 0);
}

TEST(BoneLumens, TheTorsoPhantomsArterialAortaIsNotBoneOnACoarseGrid) {
  check_phantom({192, 128, 48}, {2.5, 2.5, 3.0}, 2, 5, 1);
}

// The torso phantom with its aorta moved 35 mm forward, away from the spine (as an aorta lies
// in front of a scoliotic or displaced spine, or as an iliac artery or a contrast-filled bowel
// loop lies apart from bone), and raised to `hu` (arterial phase): the old aorta's voxels back to
// soft tissue, a cylinder of 12 mm radius along the body axis drawn at its new place. No voxel of
// it may be bone, and the rest of the mask is what it is without the rule (lumen radius 0).
void check_aorta_apart(Index3 dims, Vec3 spacing) {
  for (const std::int16_t hu : {350, 500}) {
    PhantomOptions o;
    o.dims = dims;
    o.spacing = spacing;
    PhantomTruth truth;
    CtVolume ct = make_phantom("torso", o, &truth);
    const Grid& g = ct.grid;
    // The anatomy frame as raised_aorta finds it.
    const double cx = 0.5 * static_cast<double>(dims[0]) * spacing[0];
    double cy = 0.5 * static_cast<double>(dims[1]) * spacing[1];
    const double pad = cy + 85.0;
    cy += (std::round(pad / spacing[1] - 0.5) + 0.5) * spacing[1] - pad;
    Mask vessel(g, 0);
    for (std::int64_t k = 0; k < dims[2]; ++k)
      for (std::int64_t j = 0; j < dims[1]; ++j)
        for (std::int64_t i = 0; i < dims[0]; ++i) {
          const std::size_t n = g.linear(i, j, k);
          std::int16_t& v = ct.data[n];
          if (truth.body.data[n] && !truth.bone.data[n] && v >= 235 && v <= 265) v = 40;
          const double d = std::hypot(static_cast<double>(i) * spacing[0] - cx - 30.0,
                                      static_cast<double>(j) * spacing[1] - cy + 35.5);
          if (d <= 12.0) v = hu, vessel.data[n] = 1;
        }
    const Mask before = bone_of(ct, rule_off());
    EXPECT_GT(count_in(before, {0, 0, 0}, dims), 0);
    std::int64_t vessel_bone_before = 0, vessel_bone = 0, elsewhere_differs = 0;
    const Mask bone = bone_of(ct);
    for (std::size_t n = 0; n < bone.data.size(); ++n) {
      vessel_bone_before += vessel.data[n] && before.data[n];
      vessel_bone += vessel.data[n] && bone.data[n];
      elsewhere_differs += !vessel.data[n] && bone.data[n] != before.data[n];
    }
    EXPECT_GT(vessel_bone_before, count_all(vessel) / 2) << hu << " HU: no test";
    EXPECT_EQ(vessel_bone, 0) << hu << " HU";
    EXPECT_EQ(elsewhere_differs, 0) << hu << " HU";
  }
}

TEST(BoneLumens, TheTorsoPhantomsAortaAwayFromTheSpineIsNotBone) {
  check_aorta_apart({192, 128, 48}, {2.5, 2.5, 3.0});
  check_aorta_apart({384, 256, 96}, {1.25, 1.25, 2.0});
}

}  // namespace
}  // namespace palp
