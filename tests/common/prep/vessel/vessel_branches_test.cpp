// Branches and walled-in marrow (common/prep/vessel/vessel_branches.cpp) on tiny scenes built
// here, 1 mm voxels: soft tissue at 50 HU, contrast at 300 HU, cortex at 1000 HU (cortical level
// 700). Expectations from the geometry: which voxels lie within reach of a cap, within a
// city-block clearance of a cortical voxel, or beyond a fence.
#include "prep/vessel/vessel_branches.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <vector>

namespace palp {
namespace {

constexpr double kSoftHu = 50.0;
constexpr double kLumenHu = 300.0;
constexpr double kCortexHu = 700.0;

Grid grid(Index3 dims) {
  Grid g;
  g.dims = dims;
  g.spacing = {1.0, 1.0, 1.0};
  return g;
}

std::int64_t count(const Mask& m) {
  std::int64_t n = 0;
  for (std::uint8_t v : m.data) n += v != 0;
  return n;
}

// A tube along k with a 3 x 3 voxel bore at marrow-like contrast (i, j in 10..12), k in 5..44,
// in a one-voxel cortical wall (i, j in 9..13) and soft tissue; `capped`: a cortical cap at
// k = 4 closes its lower end.
struct Tube {
  CtVolume ct;
  Mask bore, ridge;
  explicit Tube(bool capped)
      : ct(grid({24, 24, 50}), static_cast<std::int16_t>(kSoftHu), "ct"),
        bore(ct.grid, 0, "bore"),
        ridge(ct.grid, 0, "ridge") {
    for (std::int64_t k = 4; k < 45; ++k)
      for (std::int64_t j = 9; j <= 13; ++j)
        for (std::int64_t i = 9; i <= 13; ++i) {
          const bool inner = i >= 10 && i <= 12 && j >= 10 && j <= 12 && k >= 5;
          if (!inner && (k >= 5 || capped)) ct.at(i, j, k) = 1000;
          if (inner) ct.at(i, j, k) = static_cast<std::int16_t>(kLumenHu), bore.at(i, j, k) = 1;
        }
  }
};

TEST(EnclosedByCortex, AnOpenTubeIsWalledInOnFourSidesOnly) {
  const Tube tube(false);
  const double through = kSoftHu + 60.0;
  // Four walls: every bore voxel; the two open ends run out into soft tissue.
  EXPECT_EQ(count(enclosed_by_cortex(tube.ct, tube.bore, tube.ridge, kCortexHu, through, 10.0, 4)),
            9 * 40);
  EXPECT_EQ(count(enclosed_by_cortex(tube.ct, tube.bore, tube.ridge, kCortexHu, through, 10.0, 5)),
            0);
}

TEST(EnclosedByCortex, ACapEnclosesTheBoreWithinReachOfIt) {
  const Tube tube(true);
  const double through = kSoftHu + 60.0;
  // The cap at k = 4 lies k - 4 voxels below a bore voxel: met within a reach of r mm (r voxels)
  // by the slices k = 5 .. 4 + r.
  for (double reach : {3.0, 10.0, 17.0}) {
    const Mask five =
        enclosed_by_cortex(tube.ct, tube.bore, tube.ridge, kCortexHu, through, reach, 5);
    EXPECT_EQ(count(five), 9 * static_cast<std::int64_t>(reach)) << reach;
    for (std::int64_t k = 5; k < 45; ++k)
      EXPECT_EQ(five.at(11, 11, k), k <= 4 + static_cast<std::int64_t>(reach) ? 1 : 0) << k;
  }
  // Six sides: the upper end is open.
  EXPECT_EQ(count(enclosed_by_cortex(tube.ct, tube.bore, tube.ridge, kCortexHu, through, 50.0, 6)),
            0);
}

// A lumen's branch: a 3 x 3 bore along i (j, k in 10..12, i in 5..39) at contrast in soft tissue,
// the lumen seeded at its first three slices.
struct Branch {
  CtVolume ct;
  Mask body, ridge, lumen;
  std::vector<std::int16_t> hu;
  Branch()
      : ct(grid({48, 24, 24}), static_cast<std::int16_t>(kSoftHu), "ct"),
        body(ct.grid, 1, "body"),
        ridge(ct.grid, 0, "ridge"),
        lumen(ct.grid, 0, "lumen") {
    for (std::int64_t k = 10; k <= 12; ++k)
      for (std::int64_t j = 10; j <= 12; ++j)
        for (std::int64_t i = 5; i < 40; ++i) {
          ct.at(i, j, k) = static_cast<std::int16_t>(kLumenHu);
          if (i < 8) lumen.at(i, j, k) = 1;
        }
  }
  void grow(const VesselParams& params) {
    hu = ct.data;  // a uniform bore: its smoothed HU is its HU
    grow_branches(ct, body, hu, ridge, kSoftHu, kLumenHu, kLumenHu, kCortexHu, params, lumen);
  }
};

TEST(GrowBranches, KeepsItsClearanceFromACorticalVoxelAndGoesAround) {
  Branch branch;
  branch.ct.at(25, 14, 11) = 1000;  // two voxels off the bore's face j = 12
  VesselParams params;
  params.branch_clearance_mm = 3.0;  // three face steps
  branch.grow(params);
  // The bore less its voxels within 3 face steps of (25, 14, 11): |di| + |dj| + |dk| <= 3 holds
  // for (24..26, 12, 11), (25, 12, 10), (25, 12, 12) and (25, 11, 11). The bore is never closed.
  EXPECT_EQ(count(branch.lumen), 35 * 9 - 6);
  EXPECT_EQ(branch.lumen.at(25, 12, 11), 0);
  EXPECT_EQ(branch.lumen.at(25, 11, 11), 0);
  EXPECT_EQ(branch.lumen.at(25, 10, 11), 1);
  EXPECT_EQ(branch.lumen.at(39, 12, 11), 1);
}

TEST(GrowBranches, StopsAtAShellsRidgeAndAtTheLumensBandsEnd) {
  Branch branch;
  for (std::int64_t k = 10; k <= 12; ++k)
    for (std::int64_t j = 10; j <= 12; ++j) branch.ridge.at(30, j, k) = 5;  // a shell across it
  branch.ct.at(20, 11, 11) = static_cast<std::int16_t>(kLumenHu + 0.5 * (kLumenHu - kSoftHu) + 1);
  VesselParams params;
  branch.grow(params);
  // Up to i = 29, less the one voxel above the band (half the lumen's height above its level).
  EXPECT_EQ(count(branch.lumen), 25 * 9 - 1);
  EXPECT_EQ(branch.lumen.at(20, 11, 11), 0);
  EXPECT_EQ(branch.lumen.at(29, 11, 11), 1);
  EXPECT_EQ(branch.lumen.at(31, 11, 11), 0);
  // A ridge along fewer directions than the fence is no shell: the growth passes it.
  Branch passed;
  for (std::int64_t k = 10; k <= 12; ++k)
    for (std::int64_t j = 10; j <= 12; ++j) passed.ridge.at(30, j, k) = 4;
  passed.grow(params);
  EXPECT_EQ(count(passed.lumen), 35 * 9);
}

// The scan's ends: a 48 x 24 x 16 scene (k the body axis), soft tissue, no lumen in it; `paint`
// sets the HU (and the ridge) of what runs out of the scan's top slice k = 15.
struct AtTheEnd {
  CtVolume ct;
  Mask body, ridge, lumen;
  explicit AtTheEnd(Index3 dims = {48, 24, 16})
      : ct(grid(dims), static_cast<std::int16_t>(kSoftHu), "ct"),
        body(ct.grid, 1, "body"),
        ridge(ct.grid, 0, "ridge"),
        lumen(ct.grid, 0, "lumen") {}
  void box(Index3 lo, Index3 hi, double hu) {  // inclusive
    for (std::int64_t k = lo[2]; k <= hi[2]; ++k)
      for (std::int64_t j = lo[1]; j <= hi[1]; ++j)
        for (std::int64_t i = lo[0]; i <= hi[0]; ++i)
          ct.at(i, j, k) = static_cast<std::int16_t>(hu);
  }
  std::int64_t grow(double blood_hu = kLumenHu) {
    const std::vector<std::int16_t> hu = ct.data;
    grow_branches(ct, body, hu, ridge, kSoftHu, kLumenHu, blood_hu, kCortexHu, VesselParams{},
                  lumen);
    return count(lumen);
  }
};

// A branch along i (3 x 3 voxels, i 2..45 at k 11..13) that turns up out of the scan's top
// (i 43..45, k 14..15): 44 x 9 + 2 x 9 voxels, 0.41 ml, 44 mm long and 3 mm across.
void paint_branch(AtTheEnd& s, double hu) {
  s.box({2, 10, 11}, {45, 12, 13}, hu);
  s.box({43, 10, 14}, {45, 12, 15}, hu);
}

TEST(GrowBranches, ABranchTheScansEndCutsOffIsGrownFromThere) {
  AtTheEnd s;
  paint_branch(s, kLumenHu);
  EXPECT_EQ(s.grow(), 44 * 9 + 2 * 9);
  // Inside the scan (not on its ends) the same branch joined to no lumen stays out.
  AtTheEnd inside({48, 24, 18});
  paint_branch(inside, kLumenHu);
  EXPECT_EQ(inside.grow(), 0);
}

TEST(GrowBranches, WhatGrowsFromTheEndIsKeptOnlyAsATubeAsBigAsALumen) {
  AtTheEnd blob;  // 10 x 10 x 6 mm at the top: 0.6 ml, round
  blob.box({10, 6, 10}, {19, 15, 15}, kLumenHu);
  EXPECT_EQ(blob.grow(), 0);
  AtTheEnd stub;  // the branch's last 30 mm: a tube, but 0.29 ml
  stub.box({16, 10, 11}, {45, 12, 13}, kLumenHu);
  stub.box({43, 10, 14}, {45, 12, 15}, kLumenHu);
  EXPECT_LT((30 * 9 + 18) * 1e-3, VesselParams{}.min_lumen_ml);
  EXPECT_EQ(stub.grow(), 0);
}

TEST(GrowBranches, NoBranchFromTheEndDenserThanTheLumenOrWiderThanATrunksCore) {
  AtTheEnd denser;  // 400 HU, in the band (up to 425) but above the lumen's 300
  paint_branch(denser, 400.0);
  EXPECT_EQ(denser.grow(), 0);
  // A column 11 x 11 voxels along k, out of the top: 121 mm2 on the end slice, wider than
  // pi * 6^2 = 113 mm2 (a vertebral body's marrow at 5 mm slices), 10 x 10 (100 mm2) is grown.
  AtTheEnd wide({24, 24, 48});
  wide.box({6, 6, 0}, {16, 16, 47}, kLumenHu);
  EXPECT_EQ(wide.grow(), 0);
  AtTheEnd narrower({24, 24, 48});
  narrower.box({6, 6, 0}, {15, 15, 47}, kLumenHu);
  EXPECT_EQ(narrower.grow(), 10 * 10 * 48);
}

TEST(GrowBranches, ABranchFromTheEndIsJudgedByTheBloodsLevelNotTheLumensDilutedMean) {
  // The brightest lumen's mean is 300 HU (kLumenHu; an organ joined to it dilutes it), the blood
  // in its tube core 390: a branch at 380 HU is as dense as that blood, and grown; at 400 HU it
  // is denser than any blood here, and not.
  AtTheEnd branch;
  paint_branch(branch, 380.0);
  EXPECT_EQ(branch.grow(390.0), 44 * 9 + 2 * 9);
  AtTheEnd by_the_mean;
  paint_branch(by_the_mean, 380.0);
  EXPECT_EQ(by_the_mean.grow(kLumenHu), 0);
  AtTheEnd denser;
  paint_branch(denser, 400.0);
  EXPECT_EQ(denser.grow(390.0), 0);
}

TEST(GrowBranches, NoBranchFromTheEndThatCortexWallsInAcrossTheBodyAxis) {
  // A bore along k out of the top (a rib's or a pedicle's marrow cut across) in a ridge ring
  // around it: at soft-tissue HU (no clearance), along one direction (no fence), but cortex to
  // the walls' rays on all four in-plane sides.
  AtTheEnd walled({24, 24, 48});
  walled.box({10, 10, 0}, {12, 12, 47}, kLumenHu);
  for (std::int64_t k = 0; k < 48; ++k)
    for (std::int64_t j = 9; j <= 13; ++j)
      for (std::int64_t i = 9; i <= 13; ++i)
        if (i == 9 || i == 13 || j == 9 || j == 13) walled.ridge.at(i, j, k) = 1;
  EXPECT_EQ(walled.grow(), 0);
  // Open on two sides (a vessel between two ribs' edges is met on two): grown.
  AtTheEnd open({24, 24, 48});
  open.box({10, 10, 0}, {12, 12, 47}, kLumenHu);
  for (std::int64_t k = 0; k < 48; ++k)
    for (std::int64_t j = 9; j <= 13; ++j) open.ridge.at(9, j, k) = open.ridge.at(13, j, k) = 1;
  EXPECT_EQ(open.grow(), 9 * 48);
}

}  // namespace
}  // namespace palp
