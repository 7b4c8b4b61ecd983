// Tests for client_queue.hpp: the frame count and byte bounds, what is dropped first, the one
// queued SceneInfo, the order messages leave in, and the graveyard's sliced freeing.
#include "net/client_queue.hpp"

#include <gtest/gtest.h>

namespace palp::net {
namespace {

Bytes message(std::size_t size, char fill = 'm') {
  return std::make_shared<const std::string>(size, fill);
}

constexpr std::size_t kCost100 = 100 + kQueueEntryOverhead;

TEST(ClientQueue, FramesAreBoundedByCountOldestDroppedFirst) {
  ClientQueue q(3, 1 << 20);
  for (char c : std::string("abcde")) q.push_frame(message(100, c));
  EXPECT_EQ(q.frames(), 3u);
  EXPECT_EQ(q.frames_dropped(), 2u);
  EXPECT_EQ(q.bytes(), 3 * kCost100);
  std::vector<Bytes> out;
  EXPECT_EQ(q.take(out, true), 3u);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ((*out[0])[0], 'c');
  EXPECT_EQ((*out[2])[0], 'e');
  EXPECT_EQ(q.bytes(), 0u);
}

TEST(ClientQueue, StaleFramesMakeRoomForMessagesWithinTheByteBound) {
  ClientQueue q(100, 4 * kCost100);
  for (int n = 0; n < 4; ++n) q.push_frame(message(100));
  EXPECT_EQ(q.frames_dropped(), 0u);
  EXPECT_TRUE(q.push_message(message(100)));
  EXPECT_TRUE(q.push_message(message(100)));
  EXPECT_EQ(q.frames(), 2u);
  EXPECT_EQ(q.frames_dropped(), 2u);
  EXPECT_EQ(q.bytes(), 4 * kCost100);
}

TEST(ClientQueue, MessagesBeyondTheBoundWithNoFramesLeftReportOverflow) {
  ClientQueue q(100, 4 * kCost100);
  q.push_frame(message(100));
  for (int n = 0; n < 4; ++n) EXPECT_TRUE(q.push_message(message(100))) << n;
  EXPECT_EQ(q.frames(), 0u);
  EXPECT_FALSE(q.push_message(message(1)));
  EXPECT_EQ(q.bytes(), 4 * kCost100 + 1 + kQueueEntryOverhead);
}

TEST(ClientQueue, ANewerSceneReplacesTheQueuedOne) {
  ClientQueue q(100, 1 << 20);
  EXPECT_TRUE(q.push_message(message(10, 'w')));
  EXPECT_TRUE(q.push_scene(message(100, 'a')));
  EXPECT_TRUE(q.push_scene(message(50, 'b')));
  EXPECT_EQ(q.bytes(), 10 + 50 + 2 * kQueueEntryOverhead);
  q.push_frame(message(20, 'f'));
  EXPECT_TRUE(q.push_message(message(10, 'r')));
  std::vector<Bytes> out;
  EXPECT_EQ(q.take(out, false), 0u);  // frames stay until the client is ready
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ((*out[0])[0], 'w');
  EXPECT_EQ((*out[1])[0], 'r');
  EXPECT_EQ((*out[2])[0], 'b');
  EXPECT_EQ(q.frames(), 1u);
  EXPECT_EQ(q.bytes(), 20 + kQueueEntryOverhead);
}

TEST(ClientQueue, BuriedQueuesAreFreedASliceAtATime) {
  ClientQueue q(10000, 1 << 30);
  for (int n = 0; n < 5000; ++n) EXPECT_TRUE(q.push_message(message(10)));
  for (int n = 0; n < 3000; ++n) q.push_frame(message(10));
  const Bytes watched = message(10);
  EXPECT_TRUE(q.push_message(watched));
  Graveyard graveyard;
  q.bury(graveyard);
  EXPECT_EQ(q.bytes(), 0u);
  EXPECT_EQ(q.frames(), 0u);
  EXPECT_EQ(graveyard.size(), 8001u);
  EXPECT_EQ(watched.use_count(), 2);
  EXPECT_EQ(graveyard.free_some(4096), 3905u);
  EXPECT_EQ(watched.use_count(), 1);  // freed from the back of the messages
  EXPECT_EQ(graveyard.free_some(4096), 0u);
  EXPECT_EQ(graveyard.free_some(4096), 0u);
}

}  // namespace
}  // namespace palp::net
