// common/base/batch_memory.cpp: after keep_freed_memory_for_reuse, a mask-sized block comes from
// the heap (reused once freed), not from a mapping of its own, as glibc's own statistics
// (mallinfo2: hblks, the blocks mmapped) say.
#include "base/batch_memory.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <memory>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace {

#if defined(__GLIBC__)
std::size_t mapped_blocks() {
  return mallinfo2().hblks;
}

TEST(BatchMemory, AMaskSizedBlockIsNotAMappingOfItsOwn) {
  constexpr std::size_t kBytes = std::size_t{24} << 20;  // a 384x384x160 mask
  {  // glibc's default: a block this size is a mapping of its own, returned when freed
    const std::size_t before = mapped_blocks();
    const std::unique_ptr<std::uint8_t[]> block(new std::uint8_t[kBytes]);
    EXPECT_EQ(mapped_blocks(), before + 1);
  }
  palp::keep_freed_memory_for_reuse();
  const std::size_t before = mapped_blocks();
  {
    const std::unique_ptr<std::uint8_t[]> block(new std::uint8_t[kBytes]);
    EXPECT_EQ(mapped_blocks(), before);
  }
  // a block above glibc's largest threshold (a 512x512x400 mask) still is
  const std::unique_ptr<std::uint8_t[]> large(new std::uint8_t[std::size_t{100} << 20]);
  EXPECT_EQ(mapped_blocks(), before + 1);
}
#else
TEST(BatchMemory, AMaskSizedBlockIsNotAMappingOfItsOwn) {
  GTEST_SKIP() << "glibc's allocator only";
}
#endif

}  // namespace
