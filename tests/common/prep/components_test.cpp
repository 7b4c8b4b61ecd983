// Components' helpers (common/prep/components.cpp) that other tests do not already pin.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>

#include "prep/components.hpp"

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

}  // namespace
}  // namespace palp::segmentation
