// client/stream/dds_volume_chunks.hpp: the render volume's DDS chunks kept in any order, before or
// after the scene, and handed over once, in index order, when all are there.
#include "stream/dds_volume_chunks.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace palp::view {
namespace {

v1::VolumeChunk chunk_at(std::uint32_t k_begin) {
  v1::VolumeChunk c;
  c.set_k_begin(k_begin);
  return c;
}

std::vector<std::uint32_t> handed(DdsVolumeChunks& chunks, bool* done) {
  std::vector<std::uint32_t> order;
  *done = chunks.hand_over([&](const v1::VolumeChunk& c) { order.push_back(c.k_begin()); });
  return order;
}

TEST(DdsVolumeChunks, HandedOverOnceInIndexOrderWhenAllAreThere) {
  DdsVolumeChunks chunks;
  bool done = true;
  EXPECT_TRUE(handed(chunks, &done).empty());  // nothing held: nothing to hand over
  EXPECT_FALSE(done);
  // Out of order (as separate DDS instances arrive), a duplicate in between.
  EXPECT_TRUE(chunks.add(2, 3, chunk_at(20)));
  EXPECT_TRUE(chunks.add(0, 3, chunk_at(0)));
  EXPECT_TRUE(chunks.add(0, 3, chunk_at(0)));
  EXPECT_FALSE(chunks.complete());
  EXPECT_TRUE(handed(chunks, &done).empty());
  EXPECT_FALSE(done);
  EXPECT_EQ(chunks.held(), 2u);  // kept, not dropped, while incomplete (the scene may be late)
  EXPECT_TRUE(chunks.add(1, 3, chunk_at(10)));
  EXPECT_TRUE(chunks.complete());
  EXPECT_EQ(handed(chunks, &done), (std::vector<std::uint32_t>{0, 10, 20}));
  EXPECT_TRUE(done);
  EXPECT_EQ(chunks.held(), 0u);
  EXPECT_FALSE(chunks.complete());
}

TEST(DdsVolumeChunks, RefusesWhatNoVolumeHasAndRestartsOnANewCount) {
  DdsVolumeChunks chunks;
  EXPECT_FALSE(chunks.add(3, 3, chunk_at(0)));  // index outside its count
  EXPECT_FALSE(chunks.add(0, 0, chunk_at(0)));
  EXPECT_FALSE(chunks.add(0, DdsVolumeChunks::kMaxChunks + 1, chunk_at(0)));  // bounded
  EXPECT_EQ(chunks.held(), 0u);
  EXPECT_TRUE(chunks.add(0, 2, chunk_at(0)));
  EXPECT_TRUE(chunks.add(1, 4, chunk_at(1)));  // another volume: the old chunk goes
  EXPECT_EQ(chunks.held(), 1u);
  EXPECT_FALSE(chunks.complete());
}

}  // namespace
}  // namespace palp::view
