// Contrast-filled lumens (common/prep/vessel/vessel_segmentation.cpp) on tiny scenes built here:
// soft tissue at 40 HU with +-10 HU of deterministic noise, a tube of contrast along the body axis
// (a trunk, 9 mm in radius) beside a vertebra (a 2 mm cortex ring at 900 HU around marrow at
// 220 HU), and for the contrast phase a second trunk (a vein, 10 x 8 mm) to the patient's right
// of the first. Expectations from the geometry: which voxel centres lie in the tube.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>

#include "base/errors.hpp"
#include "prep/vessel/vessel_box.hpp"
#include "prep/vessel/vessel_segmentation.hpp"

namespace palp {
namespace {

constexpr double kSpacing = 1.5;
constexpr double kSoftHu = 40.0;

struct Scene {
  CtVolume ct;
  Mask body, tube, marrow;
  Mask branch;      // the branch's voxels beyond 15 mm from the trunk's axis, clear of its edge
  Mask tube_clear;  // the tube's voxels two voxels or more from the cortex (not its partial volume)
};

// The tube's centre at (30, 45) mm in-plane, radius 9 mm; the vertebra's at (30, 68) mm, radius
// 12 mm, cortex 2 mm: 2 mm of soft tissue between them. With `branch_radius_mm`, a branch of the
// tube's contrast leaves it along +x at z = 18 mm and runs out of the scene. With `vein_hu`, a
// vein (an elliptic tube, 10 mm across x, 8 mm across y) runs along the body axis at (70, 42) mm:
// the grid's i axis points to the patient's right, so the tube is an aorta on the front of the
// vertebra and the vein a vena cava 40 mm to its right.
Scene scene(double tube_hu, double branch_radius_mm = 0.0, double cortex_hu = 900.0,
            bool endplates = false, std::optional<double> vein_hu = std::nullopt,
            double marrow_hu = 220.0) {
  Grid g;
  g.dims = {60, 70, 24};  // 90 x 105 x 36 mm
  g.spacing = {kSpacing, kSpacing, kSpacing};
  g.world.direction = {-1, 0, 0, 0, 1, 0, 0, 0, 1};  // i toward the patient's right
  Scene s{CtVolume(g, 0, "ct"), Mask(g, 1, "body"),   Mask(g, 0, "tube"),
          Mask(g, 0, "marrow"), Mask(g, 0, "branch"), Mask(g, 0, "tube clear of the cortex")};
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const double x = (static_cast<double>(i) + 0.5) * kSpacing;
        const double y = (static_cast<double>(j) + 0.5) * kSpacing;
        const double r_tube = std::hypot(x - 30.0, y - 45.0);
        const double r_bone = std::hypot(x - 30.0, y - 68.0);
        const double z = (static_cast<double>(k) + 0.5) * kSpacing;
        const double r_branch = x > 30.0 ? std::hypot(y - 45.0, z - 18.0) : 1e9;
        // Partial volume at every edge, as a scanner's voxel averages what it covers: the
        // share of the voxel inside a circle of radius R at distance r, clamp(1/2 + (R - r)/h).
        const auto inside = [](double radius, double r) {
          return std::clamp(0.5 + (radius - r) / kSpacing, 0.0, 1.0);
        };
        double hu = kSoftHu + static_cast<double>((i * 7 + j * 13 + k * 5) % 21) - 10.0;
        if (vein_hu) {  // the ellipse's radius along the ray from its centre, for the edge
          const double e = std::hypot((x - 70.0) / 10.0, (y - 42.0) / 8.0);
          const double radius = e > 0.0 ? std::hypot(x - 70.0, y - 42.0) / e : 8.0;
          hu += inside(radius, e * radius) * (*vein_hu - hu);
        }
        hu += inside(9.0, r_tube) * (tube_hu - hu);
        hu += inside(branch_radius_mm, r_branch) * (tube_hu - hu);
        s.branch.at(i, j, k) = r_branch < branch_radius_mm - kSpacing && x > 45.0;
        // With endplates the vertebra is a body from z = 4 to 32 mm, its marrow from 6 to 30 mm.
        const double in_body = endplates ? (z > 4.0 && z < 32.0) : 1.0;
        const double in_marrow = endplates ? (z > 6.0 && z < 30.0) : 1.0;
        hu += in_body * inside(12.0, r_bone) * (cortex_hu - hu);
        hu += in_marrow * inside(10.0, r_bone) * (marrow_hu - hu);
        if (r_tube < 9.0) {
          s.tube.at(i, j, k) = 1;
          s.tube_clear.at(i, j, k) = r_bone >= 12.0 + 2.0 * kSpacing;
        }
        s.marrow.at(i, j, k) = r_bone < 10.0 && (!endplates || (z > 6.0 && z < 30.0));
        s.ct.at(i, j, k) = static_cast<std::int16_t>(hu);
      }
  return s;
}

std::int64_t count_both(const Mask& a, const Mask& b) {
  std::int64_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += a.data[i] && b.data[i];
  return n;
}

std::int64_t count(const Mask& a) {
  return count_both(a, a);
}

TEST(SegmentVessels, FindsAContrastTubeBesideAVertebraAndNotItsMarrow) {
  const Scene s = scene(350.0);
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0);
  EXPECT_EQ(r.contrast_phase, "arterial");  // 310 HU above the soft tissue
  EXPECT_EQ(count_both(r.lumen, s.tube_clear), count(s.tube_clear));
  EXPECT_GE(count_both(r.lumen, s.tube), count(s.tube) * 95 / 100);
  EXPECT_EQ(count_both(r.lumen, s.marrow), 0);
  // Beyond the tube, at most its wall's one voxel of partial volume.
  EXPECT_LE(count(r.lumen) - count(s.tube), count(s.tube) / 3);
}

TEST(SegmentVessels, APoolAsBrightAsCortexIsALumenNotCortex) {
  // 900 HU, the vertebra's cortex level: a thick flat pool is no ridge, so it stays a candidate
  // and is found (below the seed level + 1000 HU, dense cortex's level).
  const Scene s = scene(900.0);
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0);
  EXPECT_EQ(r.contrast_phase, "arterial");
  EXPECT_EQ(count_both(r.lumen, s.tube_clear), count(s.tube_clear));
  EXPECT_EQ(count_both(r.lumen, s.marrow), 0);
  VesselParams dense;
  dense.max_pool_margin_hu = 500.0;  // 800 HU: the pool now reads as dense bone
  EXPECT_EQ(count(segment_vessels(s.ct, s.body, kSoftHu, 300.0, dense).lumen), 0);
}

TEST(SegmentVessels, AVertebralBodyWalledInOnEverySideIsNoLumenAndSetsNoPhase) {
  // No contrast (the tube at soft-tissue HU), the cortex-contact rule off: the marrow between the
  // endplates would be the scan's one lumen and read `arterial`. Most of its voxels are walled in
  // on all six axis rays, so the part is marrow: no lumen, phase none.
  const Scene s = scene(kSoftHu, 0.0, 900.0, true);
  VesselParams no_shell_rule;
  no_shell_rule.max_cortex_contact = 1.0;
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0, no_shell_rule);
  EXPECT_EQ(r.lumens, 0);
  EXPECT_EQ(r.contrast_phase, "none");
  EXPECT_EQ(count(r.lumen), 0);
  EXPECT_GE(r.rejected_shell, 1);
}

TEST(SegmentVessels, MarrowInACortexIsKeptOutByTheCortexContact) {
  // The marrow's level and uniformity are a lumen's: only its cortical shell tells it apart.
  const Scene s = scene(350.0);
  VesselParams no_shell_rule;
  no_shell_rule.max_cortex_contact = no_shell_rule.max_clear_contrast_contact = 1.0;
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0, no_shell_rule);
  EXPECT_GT(count_both(r.lumen, s.marrow), count(s.marrow) / 2) << "the marrow is no test";
}

TEST(SegmentVessels, MarrowBrightAsContrastIsKeptOutWhereItsCortexWallsMostOfIt) {
  // Marrow at 320 HU (280 above the soft tissue: clearly contrast by its level alone, as a thick
  // slice's blurred endplate lifts a vertebral body's marrow) in its cortex ring, a column through
  // the scan: beside cortex along nearly all its faces, more than any lumen. The tube stays.
  const Scene s = scene(400.0, 0.0, 900.0, false, std::nullopt, 320.0);
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0);
  EXPECT_EQ(count_both(r.lumen, s.marrow), 0);
  EXPECT_EQ(count_both(r.lumen, s.tube_clear), count(s.tube_clear));
  VesselParams off;
  off.max_clear_contrast_contact = 1.0;
  EXPECT_GT(count_both(segment_vessels(s.ct, s.body, kSoftHu, 300.0, off).lumen, s.marrow),
            count(s.marrow) / 2)
      << "the marrow is no test";
}

TEST(SegmentVessels, NoContrastNoVessel) {
  const Scene s = scene(kSoftHu);
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0);
  EXPECT_EQ(r.contrast_phase, "none");
  EXPECT_EQ(count(r.lumen), 0);
}

TEST(SegmentVessels, AModerateAortaBesideAnUnenhancedVeinReadsArterial) {
  // A late arterial aorta, 120 HU above the soft tissue (below the old rule's 170 HU, which read
  // it portal-venous), beside a vena cava barely enhanced (25 HU above): the veins have not yet
  // filled, so the phase is arterial whatever the aorta's own level.
  const Scene s = scene(kSoftHu + 120.0, 0.0, 900.0, false, kSoftHu + 25.0);
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0);
  EXPECT_EQ(r.contrast_phase, "arterial");
  EXPECT_EQ(count_both(r.lumen, s.tube_clear), count(s.tube_clear));
  EXPECT_EQ(r.second_trunk_level_hu, 0.0);
}

TEST(SegmentVessels, AnAortaBesideAVeinAtItsLevelReadsPortalVenous) {
  // The aorta 220 HU above the soft tissue (the old rule's arterial) and the vena cava beside it
  // at 190: the contrast has come back through the veins.
  const Scene s = scene(kSoftHu + 220.0, 0.0, 900.0, false, kSoftHu + 190.0);
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0);
  EXPECT_EQ(r.contrast_phase, "portal-venous");
  EXPECT_EQ(count_both(r.lumen, s.tube_clear), count(s.tube_clear));
  EXPECT_NEAR(r.second_trunk_level_hu, kSoftHu + 190.0, 20.0);
  // The same vein barely enhanced: arterial again (the aorta alone is at its level).
  const Scene arterial = scene(kSoftHu + 220.0, 0.0, 900.0, false, kSoftHu + 50.0);
  EXPECT_EQ(segment_vessels(arterial.ct, arterial.body, kSoftHu, 300.0).contrast_phase, "arterial");
}

TEST(SegmentVessels, ASlabTooThinForATubeReadsThePhaseFromTheAortasLevel) {
  // 10 slices (15 mm): the trunk's core is shorter than a tube, so nothing tells the veins; the
  // brightest lumen's level decides (arterial_above_soft_hu, 170 HU above the soft tissue).
  const auto slab = [](const Scene& full) {
    Grid g = full.ct.grid;
    g.dims[2] = 10;
    CtVolume ct(g, 0, "slab");
    std::copy_n(full.ct.data.begin(), ct.size(), ct.data.begin());
    return segment_vessels(ct, Mask(g, 1, "body"), kSoftHu, 300.0);
  };
  const VesselResult moderate = slab(scene(kSoftHu + 120.0, 0.0, 900.0, false, kSoftHu + 25.0));
  ASSERT_GT(moderate.voxels, 0u);
  EXPECT_EQ(moderate.contrast_phase, "portal-venous");
  EXPECT_EQ(slab(scene(kSoftHu + 220.0)).contrast_phase, "arterial");
}

TEST(SegmentVessels, ANarrowTubeApartFromAnyTrunkIsNotAVessel) {
  // Costal cartilage or a tendon at a lumen's HU: thinner than a trunk's core.
  VesselParams params;
  params.trunk_core_mm = 10.0;  // deeper than the 9 mm tube holds
  const Scene s = scene(350.0);
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0, params);
  EXPECT_EQ(count(r.lumen), 0);
  EXPECT_GE(r.rejected_thin, 1);
}

TEST(SegmentVessels, ABranchLeavingTheTrunkAtItsContrastIsTheLumens) {
  // An 8 mm branch at 450 HU (above the bone seed level: bone's levels would take it) leaving the
  // trunk, as a carotid leaves the arch: its edge voxels are ridges, so it is no candidate beyond
  // the trunk, and only the branch rule finds it.
  const Scene s = scene(450.0, 4.0);
  ASSERT_GT(count(s.branch), 100);
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0);
  EXPECT_EQ(count_both(r.lumen, s.branch), count(s.branch));
  EXPECT_EQ(count_both(r.lumen, s.marrow), 0);
  VesselParams no_branches;
  no_branches.find_branches = false;
  const VesselResult without = segment_vessels(s.ct, s.body, kSoftHu, 300.0, no_branches);
  EXPECT_LT(count_both(without.lumen, s.branch), count(s.branch) / 2) << "the branch is no test";
}

TEST(SegmentVessels, ABranchAsNarrowAsACarotidIsTheLumensThoughItsCentreIsARidge) {
  // A 6 mm branch at 450 HU (a carotid, the coeliac trunk): four voxels across, so its voxels are
  // darker two voxels out along the long diagonals, ridges as cortex is along a few directions.
  // Only a ridge along five or more of the 13 (a shell) fences the growth: the branch is found
  // whole; with every ridge fencing it (1), less than half of it.
  const Scene s = scene(450.0, 3.0);
  ASSERT_GT(count(s.branch), 20);
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0);
  EXPECT_EQ(count_both(r.lumen, s.branch), count(s.branch));
  EXPECT_EQ(count_both(r.lumen, s.marrow), 0);
  VesselParams every_ridge;
  every_ridge.branch_fence_ridge_directions = 1;
  const VesselResult fenced = segment_vessels(s.ct, s.body, kSoftHu, 300.0, every_ridge);
  EXPECT_LT(count_both(fenced.lumen, s.branch), count(s.branch) / 2) << "the branch is no test";
}

TEST(SegmentVessels, BranchesStopAtTheCortexAroundMarrowAtTheLumensLevel) {
  // Marrow at 220 HU lies inside the band of a 350 HU lumen (195 to 505 HU), and so does a thin
  // cortex of 500 HU (an osteoporotic vertebra, or one a thick slice blurs). With no cortical
  // level and no clearance, the cortex's ridge alone fences the marrow from the branch growth.
  const Scene s = scene(350.0, 3.0, 500.0);
  VesselParams ridge_only;
  ridge_only.branch_clearance_mm = 0.0;
  ridge_only.cortex_margin_hu = 5000.0;
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0, ridge_only);
  EXPECT_EQ(count_both(r.lumen, s.marrow), 0);
  EXPECT_EQ(count_both(r.lumen, s.tube_clear), count(s.tube_clear));
}

TEST(SegmentVessels, MarrowWalledInOnEverySideIsNotALumen) {
  // With the cortex-contact rule off, a vertebral body's marrow at a lumen's level is taken as one
  // (MarrowInACortexIsKeptOutByTheCortexContact); walled in by its cortex and endplates on all six
  // axis rays, it is given back, and the tube beside it, open along its length, stays. The organ
  // rule is off too: the marrow holds no tube and is dimmer than the tube, so it would go as an
  // organ before the enclosure is asked (AnOrganDimmerThanATubeIsNoLumenEvenAboveHalfWay).
  const Scene s = scene(350.0, 0.0, 900.0, true);
  VesselParams no_shell_rule;
  no_shell_rule.max_cortex_contact = no_shell_rule.max_clear_contrast_contact = 1.0;
  no_shell_rule.organ_below_share = 0.0;
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0, no_shell_rule);
  EXPECT_EQ(count_both(r.lumen, s.marrow), 0);
  EXPECT_EQ(count_both(r.lumen, s.tube_clear), count(s.tube_clear));
  VesselParams no_enclosure = no_shell_rule;
  no_enclosure.marrow_enclosure_mm = 0.0;
  EXPECT_GT(count_both(segment_vessels(s.ct, s.body, kSoftHu, 300.0, no_enclosure).lumen, s.marrow),
            count(s.marrow) / 2)
      << "the marrow is no test";
}

// Calls f(i, j, k, x, y, z) for every voxel of `g`, with its centre in mm.
template <class F>
void for_each_centre(const Grid& g, F f) {
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i)
        f(i, j, k, (static_cast<double>(i) + 0.5) * kSpacing,
          (static_cast<double>(j) + 0.5) * kSpacing, (static_cast<double>(k) + 0.5) * kSpacing);
}

// A ball 20 mm across (a kidney's enhancing tissue) at 160 HU beside the trunk, centred at
// (72, 68, 18) mm.
Mask add_organ(Scene& s) {
  Mask organ(s.ct.grid, 0, "organ");
  for_each_centre(
      s.ct.grid, [&](std::int64_t i, std::int64_t j, std::int64_t k, double x, double y, double z) {
        const double r = std::hypot(x - 72.0, y - 68.0, z - 18.0);
        if (r > 10.0) return;
        s.ct.at(i, j, k) = static_cast<std::int16_t>(160 + (i * 7 + j * 13 + k * 5) % 21 - 10);
        organ.at(i, j, k) = r <= 10.0 - kSpacing;
      });
  return organ;
}

TEST(SegmentVessels, AnEnhancingOrganFarBelowTheArteriesIsNoLumen) {
  // Beside the 400 HU trunk, an organ (a ball 20 mm across, a kidney's or the spleen's enhancing
  // tissue) and a vein (a tube 13 mm across running 80 mm across the scene), both at 160 HU:
  // below half way from the soft tissue (40) to the trunk (220 HU), both uniform and thick enough
  // for a trunk's core. The organ is no tube and goes; the vein stays. With the rule off the
  // organ is a lumen.
  Scene s = scene(400.0);
  const Mask organ = add_organ(s);
  Mask vein(s.ct.grid, 0, "vein");
  for_each_centre(
      s.ct.grid, [&](std::int64_t i, std::int64_t j, std::int64_t k, double x, double y, double z) {
        const double r_vein = x > 5.0 && x < 85.0 ? std::hypot(y - 92.0, z - 18.0) : 1e9;
        if (r_vein > 6.5) return;
        s.ct.at(i, j, k) = static_cast<std::int16_t>(160 + (i * 7 + j * 13 + k * 5) % 21 - 10);
        vein.at(i, j, k) = r_vein <= 6.5 - kSpacing;
      });
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0);
  EXPECT_EQ(count_both(r.lumen, organ), 0);
  EXPECT_EQ(r.rejected_organ, 1);
  EXPECT_GT(count_both(r.lumen, vein) * 2, count(vein)) << "the vein, a tube, stays";
  VesselParams off;
  off.organ_below_share = 0.0;
  const VesselResult without = segment_vessels(s.ct, s.body, kSoftHu, 300.0, off);
  EXPECT_GT(count_both(without.lumen, organ) * 2, count(organ)) << "the organ is no test";
}

// The slices [first, first + n) of `s` (a shorter scan of the same scene).
Scene slices(const Scene& s, std::int64_t first, std::int64_t n) {
  Grid g = s.ct.grid;
  g.dims[2] = n;
  Scene out{CtVolume(g, 0, "ct"), Mask(g, 1, "body"),   Mask(g, 0, "tube"),
            Mask(g, 0, "marrow"), Mask(g, 0, "branch"), Mask(g, 0, "tube clear")};
  const std::size_t plane = static_cast<std::size_t>(g.dims[0] * g.dims[1]);
  for (std::size_t m = 0; m < out.ct.size(); ++m) {
    const std::size_t from = static_cast<std::size_t>(first) * plane + m;
    out.ct.data[m] = s.ct.data[from];
    out.tube.data[m] = s.tube.data[from];
  }
  return out;
}

TEST(SegmentVessels, AnOrganDimmerThanATubeIsNoLumenEvenAboveHalfWay) {
  // The trunk at 250 HU (a tube by its core, 36 mm long) and the organ at 160 HU: above half way
  // from the soft tissue (40) to the trunk, as a kidney's cortex is beside a moderately enhanced
  // aorta. Where the scan shows a tube, a part holding none and dimmer than it is an organ.
  Scene s = scene(250.0);
  const Mask organ = add_organ(s);
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0);
  EXPECT_EQ(count_both(r.lumen, organ), 0);
  EXPECT_EQ(r.rejected_organ, 1);
  EXPECT_EQ(count_both(r.lumen, s.tube_clear), count(s.tube_clear));
  VesselParams off;
  off.organ_below_share = 0.0;
  EXPECT_GT(count_both(segment_vessels(s.ct, s.body, kSoftHu, 300.0, off).lumen, organ) * 2,
            count(organ))
      << "the organ is no test";
}

TEST(SegmentVessels, WithoutATubeInTheScanAnOrganAboveHalfWayStays) {
  // The same scene in 12 slices (18 mm): the trunk's core is too short for a tube, so nothing
  // shows which part is the vessel and which an organ; the half-way rule alone judges, and the
  // organ above half way stays a lumen beside the trunk.
  Scene full = scene(250.0);
  add_organ(full);
  const Scene s = slices(full, 6, 12);
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0);
  EXPECT_EQ(r.rejected_organ, 0);
  EXPECT_GT(count_both(r.lumen, s.tube) * 10, count(s.tube) * 9) << "the trunk is found";
}

TEST(SegmentVessels, ATrunkBelowADenserVeinIsNoOrgan) {
  // A vein the injection runs up, dense with contrast (a ball 24 mm across at 900 HU), is the
  // brightest lumen; the 400 HU trunk lies below half way to it (470 HU) and its part is not
  // elongated enough to be a tube (36 mm long, 18 mm across), but its trunk core is: it stays.
  Scene s = scene(400.0);
  for_each_centre(
      s.ct.grid, [&](std::int64_t i, std::int64_t j, std::int64_t k, double x, double y, double z) {
        // partial volume at its edge, as scene() draws
        const double share = std::clamp(
            0.5 + (12.0 - std::hypot(x - 72.0, y - 85.0, z - 18.0)) / kSpacing, 0.0, 1.0);
        if (share > 0.0)
          s.ct.at(i, j, k) =
              static_cast<std::int16_t>(s.ct.at(i, j, k) + share * (900.0 - s.ct.at(i, j, k)));
      });
  const VesselResult r = segment_vessels(s.ct, s.body, kSoftHu, 300.0);
  EXPECT_GT(r.lumen_level_hu, 800.0) << "the dense vein is the brightest lumen";
  EXPECT_EQ(r.rejected_organ, 0);
  EXPECT_EQ(count_both(r.lumen, s.tube_clear), count(s.tube_clear));
}

// The scene (a trunk with a branch beside a vertebra with endplates, a vein) in 60 voxels of
// flat soft tissue on every side across the body axis: the search runs on its box, which leaves
// most of that out; with four voxels at contrast level in the padding's corners the box is the
// whole scan. Both searches find the same lumens, voxel for voxel.
TEST(SegmentVessels, TheSearchOnItsBoxFindsWhatItFindsOnTheWholeScan) {
  const Scene s = scene(400.0, 4.0, 900.0, true, 400.0);
  constexpr std::int64_t pad = 60;
  Grid g = s.ct.grid;
  g.dims[0] += 2 * pad;
  g.dims[1] += 2 * pad;
  CtVolume padded(g, static_cast<std::int16_t>(kSoftHu), "padded ct");
  const Mask body(g, 1, "body");
  for (std::int64_t k = 0; k < s.ct.grid.dims[2]; ++k)
    for (std::int64_t j = 0; j < s.ct.grid.dims[1]; ++j)
      for (std::int64_t i = 0; i < s.ct.grid.dims[0]; ++i)
        padded.at(i + pad, j + pad, k) = s.ct.at(i, j, k);
  const segmentation::VoxelBox box = vessel_search_box(padded, body, kSoftHu);
  std::int64_t boxed = 1;
  for (int a = 0; a < 3; ++a) boxed *= box.hi[a] - box.lo[a];
  ASSERT_LT(boxed * 10, static_cast<std::int64_t>(padded.size()) * 9) << "the box is no test";
  EXPECT_EQ(box.hi[2] - box.lo[2], g.dims[2]);  // the whole body axis
  CtVolume dotted = padded;
  for (std::int64_t j : {std::int64_t{0}, g.dims[1] - 1})
    for (std::int64_t i : {std::int64_t{0}, g.dims[0] - 1})
      dotted.at(i, j, 12) = static_cast<std::int16_t>(kSoftHu + 100.0);
  const segmentation::VoxelBox whole = vessel_search_box(dotted, body, kSoftHu);
  EXPECT_EQ(whole.lo, (Index3{0, 0, 0}));
  EXPECT_EQ(whole.hi, g.dims);
  const VesselResult on_box = segment_vessels(padded, body, kSoftHu, 300.0);
  const VesselResult on_scan = segment_vessels(dotted, body, kSoftHu, 300.0);
  ASSERT_GT(count(on_box.lumen), 1000);
  EXPECT_EQ(on_box.lumen.data, on_scan.lumen.data);
  EXPECT_EQ(on_box.contrast_phase, on_scan.contrast_phase);
  EXPECT_EQ(on_box.lumen.grid, padded.grid);
}

TEST(SegmentVessels, RefusesAMaskOnAnotherGrid) {
  const Scene s = scene(350.0);
  Grid other = s.ct.grid;
  other.dims[2] = 3;
  EXPECT_THROW(segment_vessels(s.ct, Mask(other, 1), kSoftHu, 300.0), UsageError);
}

}  // namespace
}  // namespace palp
