// Face-neighbour morphology of whole masks (common/prep/segment/morphology.cpp) on tiny grids:
// expectations from counting faces (a voxel and its six neighbours, fewer at the grid's border).
#include "prep/segment/morphology.hpp"

#include <gtest/gtest.h>

#include <cstdint>

namespace palp::segmentation {
namespace {

Mask mask(Index3 dims) {
  Grid g;
  g.dims = dims;
  return Mask(g, 0, "mask");
}

std::int64_t count(const Mask& m) {
  std::int64_t n = 0;
  for (std::uint8_t v : m.data) n += v != 0;
  return n;
}

TEST(Morphology, DilationAddsTheSixFaceNeighboursAndKeepsValues) {
  Mask m = mask({7, 6, 5});
  m.at(3, 2, 2) = 9;  // inside: six faces
  m.at(0, 0, 0) = 1;  // a corner: three faces within the grid
  const Mask d = dilate_once(m);
  EXPECT_EQ(count(d), 7 + 4);
  EXPECT_EQ(d.at(3, 2, 2), 9);  // its own value kept
  for (auto [i, j, k] : {Index3{2, 2, 2}, Index3{4, 2, 2}, Index3{3, 1, 2}, Index3{3, 3, 2},
                         Index3{3, 2, 1}, Index3{3, 2, 3}})
    EXPECT_EQ(d.at(i, j, k), 1);
  EXPECT_EQ(d.at(4, 3, 2), 0);  // an edge neighbour is not a face neighbour
  EXPECT_EQ(d.at(1, 0, 0) + d.at(0, 1, 0) + d.at(0, 0, 1), 3);
  // the last voxel of a row and a one-voxel-wide grid
  Mask end = mask({5, 1, 1});
  end.at(4, 0, 0) = 1;
  EXPECT_EQ(count(dilate_once(end)), 2);
  Mask thin = mask({1, 3, 1});
  thin.at(0, 1, 0) = 1;
  EXPECT_EQ(count(dilate_once(thin)), 3);
}

TEST(Morphology, DilationIntoAllowedVoxelsOnly) {
  Mask m = mask({7, 6, 5});
  m.at(3, 2, 2) = 1;
  Mask out;
  dilate_into(
      m, [&](std::size_t n) { return n != m.grid.linear(4, 2, 2); }, out);
  EXPECT_EQ(count(out), 6);
  EXPECT_EQ(out.at(4, 2, 2), 0);
}

TEST(Morphology, ErosionOfACubeLeavesItsCentreAndTheBorderKeepsItsVoxels) {
  Mask cube = mask({9, 9, 9});
  for (std::int64_t k = 3; k <= 5; ++k)
    for (std::int64_t j = 3; j <= 5; ++j)
      for (std::int64_t i = 3; i <= 5; ++i) cube.at(i, j, k) = 1;
  Mask out;
  erode_into(cube, out);
  EXPECT_EQ(count(out), 1);
  EXPECT_EQ(out.at(4, 4, 4), 1);
  // A full grid stays full: outside the scan counts as set.
  Mask full = mask({4, 3, 2});
  for (auto& v : full.data) v = 1;
  erode_into(full, out);
  EXPECT_EQ(count(out), 4 * 3 * 2);
}

TEST(Morphology, OutputsReuseTheirMemoryAndArithmeticIsVoxelwise) {
  Mask a = mask({6, 5, 4}), b = mask({6, 5, 4});
  a.at(1, 1, 1) = 1;
  b.at(1, 1, 1) = b.at(2, 2, 2) = 1;
  Mask out = mask({6, 5, 4});
  const std::uint8_t* before = out.data.data();
  erode_into(b, out);
  EXPECT_EQ(out.data.data(), before);
  EXPECT_EQ(count(out), 0);
  unite(b, a);
  EXPECT_EQ(count(a), 2);
  Mask c = mask({6, 5, 4});
  c.at(2, 2, 2) = 1;
  remove(c, a);
  EXPECT_EQ(count(a), 1);
  EXPECT_EQ(a.at(1, 1, 1), 1);
}

TEST(Morphology, TheNonzeroBoxAndStepsWithinItEqualTheWholeGrids) {
  Mask m = mask({12, 10, 9});
  EXPECT_EQ(nonzero_box(m, 2).hi, (Index3{0, 0, 0}));  // empty
  m.at(5, 4, 3) = m.at(6, 4, 3) = m.at(6, 5, 4) = 1;
  const VoxelBox box = nonzero_box(m, 2);
  EXPECT_EQ(box.lo, (Index3{3, 2, 1}));
  EXPECT_EQ(box.hi, (Index3{9, 8, 7}));
  EXPECT_EQ(nonzero_box(m, 9).lo, (Index3{0, 0, 0}));  // clamped to the grid
  EXPECT_EQ(nonzero_box(m, 9).hi, (Index3{12, 10, 9}));
  // Two dilations and two erosions within the mask's box grown by two: the whole grid's result.
  const auto everywhere = [](std::size_t) { return true; };
  Mask a, b, c, d;
  dilate_into(m, everywhere, a, box);
  dilate_into(a, everywhere, b, box);
  erode_into(b, c, box);
  erode_into(c, d, box);
  Mask wa, wb, wc, wd;
  dilate_into(m, everywhere, wa);
  dilate_into(wa, everywhere, wb);
  erode_into(wb, wc);
  erode_into(wc, wd);
  EXPECT_EQ(b.data, wb.data);
  EXPECT_EQ(d.data, wd.data);
  EXPECT_EQ(count(b), count(dilate_once(dilate_once(m))));
}

}  // namespace
}  // namespace palp::segmentation
