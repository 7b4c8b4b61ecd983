// palpview's DDS source (client/stream/dds_source.cpp) against palpd --dds on loopback: the same
// LatestState as over palp.v1 (scene, the render volume, frames with contacts, stats), observer
// only. Its own DDS domain and a loopback-only Cyclone configuration (support/dds_loopback.hpp).
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>

#include "base/errors.hpp"
#include "stream/stream_client.hpp"
#include "support/dds_loopback.hpp"
#include "support/palpd_process.hpp"

namespace palp::view {
namespace {

namespace fs = std::filesystem;

LatestState wait_for(const StreamClient& client, const std::function<bool(const LatestState&)>& ok,
                     double seconds = 30) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  LatestState s = client.latest();
  while (!ok(s) && std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    s = client.latest();
  }
  return s;
}

TEST(DdsSource, ObserverOnly) {
  StreamOptions o;
  o.dds = true;
  o.controller = true;
  EXPECT_THROW(StreamClient{o}, UsageError);
  o.controller = false;
  o.host.clear();
  o.port = 0;
  EXPECT_NO_THROW(StreamClient{o});  // no host or port needed
}

TEST(DdsSource, SceneVolumeAndFramesFromPalpdDds) {
  testing::use_dds_loopback();
  const std::uint32_t domain = testing::unique_dds_domain();
  const fs::path log = fs::temp_directory_path() / ("palp_dds_source_" + std::to_string(getpid()));
  const int port = testing::start_palpd(
      "--scene phantom:sphere --device sim --port 0 --duration 8 "
      "--dds " +
          std::to_string(domain) + " --rig view --dds-volume-max-dim 32",
      log);
  ASSERT_GT(port, 0) << testing::read_text(log);
  StreamOptions o;
  o.dds = true;
  o.dds_domain = domain;
  o.dds_rig = "view";
  StreamClient client(o);
  client.start();
  LatestState s = wait_for(client, [](const LatestState& l) {
    return l.link.state == LinkState::Live && l.volume && l.scene && l.frame.valid &&
           l.link.latency_ms > -1 && l.link.delivered >= 0;
  });
  ASSERT_EQ(s.link.state, LinkState::Live) << s.link.message;
  ASSERT_TRUE(s.scene);
  EXPECT_EQ(s.scene->source, "phantom:sphere");
  EXPECT_EQ(s.scene->tool_points.size(), 37u);
  EXPECT_EQ(s.scene->tick_rate_hz, 1000.0);
  ASSERT_TRUE(s.volume);  // 100 voxels an axis at most 32: every 4th, as palp.v1 plans it
  EXPECT_EQ(s.volume->step, 4u);
  EXPECT_EQ(s.volume->d_surf.size(), 25u * 25u * 25u);
  EXPECT_EQ(s.link.volume_progress, 1.0);
  EXPECT_EQ(s.frame.contact_points, 37u);
  EXPECT_EQ(s.frame.contacts.size(), 37u);  // frames_contacts (want_contacts by default)
  EXPECT_GT(s.link.frames, 0u);
  EXPECT_GT(s.link.delivered, 0.0);
  EXPECT_LE(s.link.delivered, 1.0);
  // Same host: the offset from the frames' stamps is near 0, the latency small and positive.
  EXPECT_GE(s.link.latency_ms, 0.0);
  EXPECT_LT(s.link.latency_ms, 1000.0);
  EXPECT_EQ(s.link.connections, 1u);
  client.stop();
  client.stop();  // idempotent
  EXPECT_TRUE(testing::wait_palpd_exit(log));
  fs::remove(log);
}

}  // namespace
}  // namespace palp::view
