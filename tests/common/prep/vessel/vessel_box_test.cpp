// The vessel search's box and crops (common/prep/vessel/vessel_box.cpp) on tiny scenes: the box
// from where the bright voxels are and the reach in millimetres, the crop's placement in the world.
#include "prep/vessel/vessel_box.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "base/errors.hpp"

namespace palp {
namespace {

Grid grid(Index3 dims, Vec3 spacing) {
  Grid g;
  g.dims = dims;
  g.spacing = spacing;
  g.world.origin = {10.0, -20.0, 30.0};
  return g;
}

TEST(VesselBox, TheBrightVoxelsGrownByTheReachAndTheWholeBodyAxis) {
  // 2 x 2 x 3 mm voxels: the reach is max(30, 25 + 6) = 31 mm: 16 voxels + 2 across, the body
  // axis (k, the grid's own direction) whole.
  const Grid g = grid({100, 90, 40}, {2.0, 2.0, 3.0});
  CtVolume ct(g, 40, "ct");
  Mask body(g, 1, "body");
  EXPECT_EQ(vessel_search_box(ct, body, 40.0).hi, (Index3{0, 0, 0}));  // nothing bright
  ct.at(50, 45, 20) = 100;  // the candidates' level: 40 + 60
  segmentation::VoxelBox box = vessel_search_box(ct, body, 40.0);
  EXPECT_EQ(box.lo, (Index3{50 - 18, 45 - 18, 0}));
  EXPECT_EQ(box.hi, (Index3{51 + 18, 46 + 18, 40}));
  ct.at(50, 45, 20) = 99;  // below it: nothing
  EXPECT_EQ(vessel_search_box(ct, body, 40.0).hi, (Index3{0, 0, 0}));
  ct.at(3, 45, 20) = 500;  // near the edge: clamped to the grid
  box = vessel_search_box(ct, body, 40.0);
  EXPECT_EQ(box.lo[0], 0);
  body.at(3, 45, 20) = 0;  // outside the body: not counted
  EXPECT_EQ(vessel_search_box(ct, body, 40.0).hi, (Index3{0, 0, 0}));
  const Mask other(grid({10, 9, 4}, {2.0, 2.0, 3.0}), 1, "other");
  EXPECT_THROW(vessel_search_box(ct, other, 40.0), UsageError);
}

TEST(VesselBox, ACropSitsWhereItWasAndPastesBack) {
  const Grid g = grid({8, 7, 6}, {0.5, 1.0, 2.0});
  CtVolume ct(g, 0, "ct");
  for (std::size_t n = 0; n < ct.size(); ++n) ct.data[n] = static_cast<std::int16_t>(n);
  const segmentation::VoxelBox box{{2, 1, 3}, {7, 5, 6}};
  const CtVolume part = crop(ct, box);
  EXPECT_EQ(part.grid.dims, (Index3{5, 4, 3}));
  EXPECT_EQ(part.at(0, 0, 0), ct.at(2, 1, 3));
  EXPECT_EQ(part.at(4, 3, 2), ct.at(6, 4, 5));
  // voxel (0, 0, 0) of the crop is voxel (2, 1, 3) of the scan: 1, 1 and 6 mm from its origin
  EXPECT_DOUBLE_EQ(part.grid.world.origin[0], 11.0);
  EXPECT_DOUBLE_EQ(part.grid.world.origin[1], -19.0);
  EXPECT_DOUBLE_EQ(part.grid.world.origin[2], 36.0);
  Mask m(g, 0, "mask");
  m.at(4, 2, 4) = 1;
  Mask whole(g, 0, "whole");
  paste(crop(m, box), box, whole);
  EXPECT_EQ(whole.data, m.data);
}

TEST(VesselBox, ACropPaysWhereItSavesATenthOfTheGrid) {
  // 1000 voxels: a box of 900 saves exactly a tenth, one of 910 less; an empty box is no crop
  segmentation::VoxelBox box{{0, 0, 0}, {9, 10, 10}};
  EXPECT_TRUE(box_saves_a_tenth(box, 1000));
  box.hi = {10, 10, 10};
  EXPECT_FALSE(box_saves_a_tenth(box, 1000));
  box.hi = {7, 13, 10};  // 910
  EXPECT_FALSE(box_saves_a_tenth(box, 1000));
  box.hi = {0, 0, 0};
  EXPECT_FALSE(box_saves_a_tenth(box, 1000));
}

}  // namespace
}  // namespace palp
