// palpd's render-volume chunk cache (server/net/volume_cache.cpp): the frames are those
// fill_volume_chunk gives, byte for byte, encoded once per plan and shared, the plans kept bounded.
#include "net/volume_cache.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

#include "net/protocol.hpp"
#include "support/palpd_test_util.hpp"

namespace palp::net {
namespace {

SceneDescription ball_scene() {
  SceneDescription scene;
  scene.fields = testing::ball_fields();
  scene.grid = scene.fields->grid();
  auto ct = std::make_shared<CtVolume>(scene.grid);
  auto body = std::make_shared<Mask>(scene.grid);
  for (std::size_t v = 0; v < ct->data.size(); ++v) {
    ct->data[v] = static_cast<std::int16_t>(v % 3000 - 1000);
    body->data[v] = (v / 32) % 32 > 8 ? 1 : 0;  // j > 8
  }
  scene.ct = ct;
  scene.body = body;
  return scene;
}

// Waits until every chunk of `frames` is encoded (the encoders run on their own threads).
void wait_encoded(const VolumeCache::Frames& frames) {
  for (int i = 0; i < 2000 && frames.encoded() < frames.plan().chunks; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_EQ(frames.encoded(), frames.plan().chunks);
}

TEST(VolumeCache, FramesAreTheChunksEncodedOnceAndShared) {
  const SceneDescription scene = ball_scene();
  std::atomic<int> notified{0};
  VolumeCache cache(
      scene, 4096, [&] { ++notified; }, false, 3);
  const VolumePlan plan = cache.plan({1, 0, true, false, true, true});
  ASSERT_GT(plan.chunks, 3u);
  EXPECT_EQ(plan.offset[1], 9 - 5);  // the body from j = 9, less the 10 mm margin (5 voxels)
  const auto frames = cache.get(plan);
  wait_encoded(*frames);
  EXPECT_EQ(notified.load(), static_cast<int>(plan.chunks));
  for (std::uint32_t c = 0; c < plan.chunks; ++c) {
    v1::ServerMessage m;
    fill_volume_chunk(scene, plan, c * plan.slab, c, m.mutable_volume());
    ASSERT_TRUE(frames->frame(c));
    EXPECT_EQ(*frames->frame(c), *frame_of(m)) << "chunk " << c;
  }
  EXPECT_FALSE(frames->frame(plan.chunks));
  // The same plan again: the same frames, nothing encoded again.
  EXPECT_EQ(cache.get(cache.plan({1, 0, true, false, true, true})), frames);
  EXPECT_EQ(notified.load(), static_cast<int>(plan.chunks));
}

TEST(VolumeCache, EncodersRunTenNiceLevelsBelowTheIoThread) {
  const SceneDescription scene = ball_scene();
  const int io_nice = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid()));
  std::atomic<int> encoder_nice{-100};
  VolumeCache cache(  // notify runs on the encoder thread that finished a chunk
      scene, 4096, [&] { encoder_nice = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid())); },
      false, 1);
  const auto frames = cache.get(cache.plan({1, 0, true, false, true, true}));
  wait_encoded(*frames);
  EXPECT_EQ(encoder_nice.load(), std::min(19, io_nice + 10));
  EXPECT_EQ(getpriority(PRIO_PROCESS, static_cast<id_t>(gettid())), io_nice);  // the caller's kept
}

TEST(VolumeCache, KeepsAtMostMaxPlansAndAHolderKeepsItsFrames) {
  const SceneDescription scene = ball_scene();
  VolumeCache cache(scene, 4096, {}, false, 2, 1);
  const VolumePlan a = cache.plan({2, 0, true, false, true, false});
  const VolumePlan b = cache.plan({4, 0, true, false, true, false});
  const auto fa = cache.get(a);
  wait_encoded(*fa);
  const auto fb = cache.get(b);  // evicts a from the cache; this holder keeps it
  wait_encoded(*fb);
  EXPECT_TRUE(fa->frame(0));
  EXPECT_NE(cache.get(a), fa);  // a was encoded again
  wait_encoded(*cache.get(a));
}

TEST(VolumeCache, WarmEncodesTheViewersDefaultAtStart) {
  const SceneDescription scene = ball_scene();
  VolumeCache cache(scene, 4096, {}, true);
  const auto frames = cache.get(cache.plan(kViewerDefaultRequest));
  wait_encoded(*frames);
  EXPECT_TRUE(frames->plan().hu);
}

}  // namespace
}  // namespace palp::net
