// FrameBatcher (server/interop/dds_batch.*): which frames go in one frame_batch sample, when it
// is due, its bounds. Deadlines and indices are exact numbers.
#include "interop/dds_batch.hpp"

#include <gtest/gtest.h>

#include <cstdint>

#include "base/errors.hpp"

namespace palp::interop {
namespace {

constexpr std::int64_t kMs = 1000000;

palp_dds_BatchFrame frame(std::uint64_t index, std::int64_t t_ns) {
  palp_dds_BatchFrame f{};
  f.frame_index = index;
  f.seq = index + 100;
  f.server_time_ns = t_ns;
  f.force = {0.5 * static_cast<double>(index), 0, 0};
  return f;
}

TEST(FrameBatcher, TenMillisecondsAtOneKilohertzAreTenFrames) {
  FrameBatcher b("bed1", 10 * kMs, kMs);
  EXPECT_EQ(b.capacity(), 11u);
  for (std::uint64_t i = 0; i < 9; ++i) {
    EXPECT_FALSE(b.due_before(static_cast<std::int64_t>(i) * kMs));
    b.add(frame(i, static_cast<std::int64_t>(i) * kMs));
    EXPECT_FALSE(b.complete()) << i;
  }
  b.add(frame(9, 9 * kMs));  // the next, at 10 ms, would lie outside the window
  ASSERT_TRUE(b.complete());
  const palp_dds_FrameBatch& s = b.sample();
  EXPECT_STREQ(s.rig, "bed1");
  EXPECT_EQ(s.batch_index, 0u);
  ASSERT_EQ(s.frames._length, 10u);
  EXPECT_EQ(s.frames._maximum, 11u);
  EXPECT_FALSE(s.frames._release);
  for (std::uint32_t i = 0; i < 10; ++i) {
    EXPECT_EQ(s.frames._buffer[i].frame_index, i);
    EXPECT_EQ(s.frames._buffer[i].seq, i + 100);
    EXPECT_EQ(s.frames._buffer[i].force.x, 0.5 * i);
  }
  b.clear();
  EXPECT_EQ(b.size(), 0u);
  EXPECT_EQ(b.batches(), 1u);
  b.add(frame(10, 10 * kMs));
  EXPECT_EQ(b.sample().batch_index, 1u);
  EXPECT_EQ(b.sample().frames._buffer[0].frame_index, 10u);
  b.drop();  // no reader: forgotten, the next batch keeps index 1
  EXPECT_EQ(b.size(), 0u);
  b.add(frame(20, 20 * kMs));
  EXPECT_EQ(b.sample().batch_index, 1u);
  EXPECT_EQ(b.sample().frames._length, 1u);
}

TEST(FrameBatcher, AFrameOutsideTheWindowEndsTheBatchBeforeIt) {
  FrameBatcher b("r", 10 * kMs, kMs);
  b.add(frame(0, 0));
  b.add(frame(1, kMs));
  EXPECT_FALSE(b.due_before(9 * kMs));
  EXPECT_TRUE(b.due_before(10 * kMs));  // frames 2..9 were dropped before publishing
  EXPECT_TRUE(b.due_before(15 * kMs));
}

TEST(FrameBatcher, StaleAWindowAfterTheWindowWithNoFrame) {
  FrameBatcher b("r", 10 * kMs, kMs);
  EXPECT_FALSE(b.stale(100 * kMs));  // nothing pending
  b.add(frame(0, 5 * kMs));
  EXPECT_FALSE(b.stale(15 * kMs));  // frames reach the DDS thread after their deadlines
  EXPECT_FALSE(b.stale(25 * kMs - 1));
  EXPECT_TRUE(b.stale(25 * kMs));
}

TEST(FrameBatcher, ARateThatDoesNotDivideTheWindow) {
  // 3 kHz: 333333 ns apart; frames 0..30 lie within 10 ms of the first, frame 31 does not.
  const std::int64_t period = 333333;
  FrameBatcher b("r", 10 * kMs, period);
  EXPECT_EQ(b.capacity(), 32u);
  for (std::uint64_t i = 0; i < 30; ++i) {
    b.add(frame(i, static_cast<std::int64_t>(i) * period));
    EXPECT_FALSE(b.complete()) << i;
  }
  b.add(frame(30, 30 * period));
  EXPECT_TRUE(b.complete());
  EXPECT_EQ(b.size(), 31u);
}

TEST(FrameBatcher, FullIsCompleteAndTakesNoMore) {
  FrameBatcher b("r", 10 * kMs, 0);  // period unknown: as many as the type allows
  EXPECT_EQ(b.capacity(), static_cast<std::size_t>(palp_dds_kMaxBatchFrames));
  for (std::uint64_t i = 0; i < b.capacity(); ++i) b.add(frame(i, 0));
  EXPECT_TRUE(b.complete());
  b.add(frame(5000, 0));
  EXPECT_EQ(b.size(), b.capacity());
  EXPECT_EQ(b.sample().frames._buffer[b.capacity() - 1].frame_index, b.capacity() - 1);
}

TEST(FrameBatcher, Bounds) {
  EXPECT_NO_THROW(FrameBatcher("r", 100 * kMs, 100000));  // 100 ms at 10 kHz: 1000 frames
  EXPECT_EQ(FrameBatcher("r", 100 * kMs, 100000).capacity(), 1001u);
  EXPECT_THROW(FrameBatcher("r", 200 * kMs, 100000), UsageError);  // 2000 frames
  EXPECT_THROW(FrameBatcher("r", 0, kMs), UsageError);
}

}  // namespace
}  // namespace palp::interop
