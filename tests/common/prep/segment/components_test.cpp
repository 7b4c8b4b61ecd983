// Components' helpers (common/prep/segment/components.cpp) that other tests do not already pin.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "prep/segment/components.hpp"

namespace palp::segmentation {
namespace {

// count_nonzero counts in byte lanes emptied every 255 blocks: sizes on both sides of a block,
// values that are not 0/1, and every byte set, so a lane that overflowed would show.
TEST(CountNonzero, CountsEveryNonzeroByteWhateverTheSize) {
  for (const std::int64_t nx : {1, 21, 64, 65, 5439, 5440, 5441, 16384}) {
    Grid grid;  // nx * 3: 16317 .. 16323 straddles one block of 64 * 255 bytes
    grid.dims = {nx, 3, 1};
    Mask mask(grid, 0, "test");
    std::uint64_t expected = 0;
    for (std::size_t v = 0; v < mask.data.size(); ++v) {
      mask.data[v] = static_cast<std::uint8_t>((v * 7919u) % 5 == 0 ? 0 : (v % 255) + 1);
      expected += mask.data[v] != 0 ? 1 : 0;
    }
    EXPECT_EQ(count_nonzero(mask), expected) << "nx " << nx;
    std::fill(mask.data.begin(), mask.data.end(), std::uint8_t{255});
    EXPECT_EQ(count_nonzero(mask), mask.data.size()) << "nx " << nx;
  }
}

// last_nonzero_byte reads whole words from the end: every length around a word, the nonzero byte
// at every place (and none), with zeros and nonzero bytes beyond n that must not count.
TEST(LastNonzeroByte, FindsTheLastNonzeroByteBeforeN) {
  for (std::int64_t n = 0; n <= 20; ++n) {
    std::vector<std::uint8_t> row(static_cast<std::size_t>(n) + 8, 0);
    std::fill(row.begin() + n, row.end(), std::uint8_t{1});  // beyond n
    EXPECT_EQ(last_nonzero_byte(row.data(), n), -1) << "n " << n;
    for (std::int64_t at = 0; at < n; ++at) {
      row[static_cast<std::size_t>(at)] = static_cast<std::uint8_t>(at + 1);
      EXPECT_EQ(last_nonzero_byte(row.data(), n), at) << "n " << n << " at " << at;
      if (at > 0) row[0] = 7;  // an earlier nonzero byte changes nothing
      EXPECT_EQ(last_nonzero_byte(row.data(), n), at) << "n " << n << " at " << at;
      row[0] = 0;
      row[static_cast<std::size_t>(at)] = 0;
    }
  }
}

// transpose_bytes_8x8 against the definition, with strides wider than the block (and bytes
// around it that must stay as they are).
TEST(TransposeBytes8x8, MovesEveryByteToItsTransposedPlace) {
  constexpr std::int64_t kSrc = 11, kDst = 13;
  std::vector<std::uint8_t> src(8 * kSrc), dst(8 * kDst, 0xEE);
  for (std::size_t n = 0; n < src.size(); ++n) src[n] = static_cast<std::uint8_t>(n * 37 + 5);
  transpose_bytes_8x8(src.data(), kSrc, dst.data(), kDst);
  for (std::int64_t c = 0; c < 8; ++c)  // row c of dst: column c of src, then untouched bytes
    for (std::int64_t r = 0; r < kDst; ++r)
      EXPECT_EQ(dst[static_cast<std::size_t>(c * kDst + r)],
                r < 8 ? src[static_cast<std::size_t>(r * kSrc + c)] : std::uint8_t{0xEE})
          << r << ", " << c;
}

// nonzero_where: the nonzero voxels the predicate keeps, every slice's, in linear order.
TEST(NonzeroWhere, ListsTheKeptNonzeroVoxelsInOrder) {
  Grid grid;
  grid.dims = {19, 5, 7};
  Mask mask(grid, 0, "test");
  std::vector<std::size_t> expected;
  for (std::size_t n = 0; n < mask.data.size(); ++n) {
    mask.data[n] = static_cast<std::uint8_t>(n % 3 == 0 ? 0 : n % 7 + 1);
    if (mask.data[n] != 0 && n % 2 == 0) expected.push_back(n);
  }
  EXPECT_EQ(nonzero_where(mask, [](std::size_t n) { return n % 2 == 0; }), expected);
  EXPECT_TRUE(nonzero_where(Mask(grid, 0, "empty"), [](std::size_t) { return true; }).empty());
}

// Two components, one an L across rows and slices: each box is exactly its voxels' extent.
TEST(ComponentBoxes, AreEachComponentsExtent) {
  Grid grid;
  grid.dims = {8, 6, 5};
  Mask mask(grid, 0, "test");
  mask.at(1, 1, 1) = mask.at(2, 1, 1) = mask.at(3, 1, 1) = 1;  // the L: a run...
  mask.at(3, 2, 1) = mask.at(3, 3, 1) = mask.at(3, 3, 2) = 1;  // ...turning along j, then k
  mask.at(6, 5, 4) = mask.at(7, 5, 4) = 1;                     // apart, at the far corner
  const RunTable runs = extract_runs(mask, false);
  const RunLabels labels = label_runs(grid, runs);
  ASSERT_EQ(labels.voxels.size(), 2u);
  const std::vector<ComponentBox> boxes = component_boxes(grid, runs, labels);
  ASSERT_EQ(boxes.size(), 2u);
  EXPECT_EQ(boxes[0].lo, (Index3{1, 1, 1}));
  EXPECT_EQ(boxes[0].hi, (Index3{3, 3, 2}));
  EXPECT_EQ(boxes[1].lo, (Index3{6, 5, 4}));
  EXPECT_EQ(boxes[1].hi, (Index3{7, 5, 4}));
}

}  // namespace
}  // namespace palp::segmentation
