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
    grow_branches(ct, body, hu, ridge, kSoftHu, kLumenHu, kCortexHu, params, lumen);
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

}  // namespace
}  // namespace palp
