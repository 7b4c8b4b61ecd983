// Grids and volumes: indexing, validation, the allocation guard and the memory readings.
#include "base/volume.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "base/errors.hpp"

namespace palp {
namespace {

Grid grid_of(Index3 dims, Vec3 spacing) {
  Grid g;
  g.dims = dims;
  g.spacing = spacing;
  return g;
}

TEST(Grid, IndexesWithIFastest) {
  const Grid g = grid_of({4, 3, 2}, {0.5, 1.0, 2.0});
  EXPECT_EQ(g.voxel_count(), 24u);
  EXPECT_EQ(g.linear(0, 0, 0), 0u);
  EXPECT_EQ(g.linear(1, 0, 0), 1u);
  EXPECT_EQ(g.linear(0, 1, 0), 4u);
  EXPECT_EQ(g.linear(3, 2, 1), 23u);
  EXPECT_TRUE(g.contains(3, 2, 1));
  EXPECT_FALSE(g.contains(4, 0, 0));
  EXPECT_FALSE(g.contains(0, -1, 0));
  EXPECT_EQ(g.extent_mm(), (Vec3{1.5, 2.0, 2.0}));
  EXPECT_EQ(g.min_spacing(), 0.5);
}

TEST(Grid, RefusesUnusableDimensionsAndSpacing) {
  EXPECT_NO_THROW(validate_grid(grid_of({1, 1, 1}, {1, 1, 1}), "x"));
  EXPECT_THROW(validate_grid(grid_of({0, 5, 5}, {1, 1, 1}), "x"), InputError);
  EXPECT_THROW(validate_grid(grid_of({5, -1, 5}, {1, 1, 1}), "x"), InputError);
  EXPECT_THROW(validate_grid(grid_of({5, 5, kMaxVoxelsPerAxis + 1}, {1, 1, 1}), "x"), InputError);
  EXPECT_THROW(validate_grid(grid_of({5, 5, 5}, {1, 0, 1}), "x"), InputError);
  // Absurd spacings (a lying header or a wrong unit) are refused, naming the range.
  for (double sp : {1e-9, 1e-30, 1e300, 0.0009, 100.5}) {
    try {
      validate_grid(grid_of({5, 5, 5}, {1, sp, 1}), "x");
      ADD_FAILURE() << sp;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("[0.001, 100] mm"), std::string::npos) << e.what();
    }
  }
  EXPECT_NO_THROW(validate_grid(grid_of({5, 5, 5}, {0.001, 100, 1}), "x"));
  EXPECT_THROW(validate_grid(grid_of({5, 5, 5}, {1, std::nan(""), 1}), "x"), InputError);
  EXPECT_THROW(validate_grid(grid_of({5, 5, 5}, {1, 1, INFINITY}), "x"), InputError);
  try {
    validate_grid(grid_of({0, 5, 5}, {1, 1, 1}), "scan.nii");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("scan.nii"), std::string::npos);
  }
}

TEST(Volume, RefusesBeforeAllocatingWhatCannotFit) {
  // 16384^3 voxels of float: 16 TiB, more than any machine this runs on.
  const Grid huge = grid_of({kMaxVoxelsPerAxis, kMaxVoxelsPerAxis, kMaxVoxelsPerAxis}, {1, 1, 1});
  EXPECT_THROW(check_allocation(huge, sizeof(float), "map"), ResourceError);
  EXPECT_THROW(DistanceMap(huge, 0.0f, "map"), ResourceError);
  EXPECT_NO_THROW(check_allocation(grid_of({64, 64, 64}, {1, 1, 1}), 4, "map"));
}

TEST(Volume, FillsAndIndexes) {
  Mask m(grid_of({3, 2, 2}, {1, 1, 1}), 7);
  EXPECT_EQ(m.size(), 12u);
  for (auto v : m.data) EXPECT_EQ(v, 7);
  m.at(2, 1, 1) = 1;
  EXPECT_EQ(m.data.back(), 1);
}

TEST(Memory, PeakGrowsWhenMemoryIsTouched) {
  EXPECT_GT(available_memory_bytes(), 0u);
  const std::size_t before = peak_rss_bytes();
  ASSERT_GT(before, 0u);
  std::vector<char> block(64u << 20);
  std::memset(block.data(), 1, block.size());
  const std::size_t after = peak_rss_bytes();
  EXPECT_GE(after, before + (48u << 20)) << "64 MiB touched";
  EXPECT_EQ(block[12345], 1);
}

}  // namespace
}  // namespace palp
