// The palpd network server over loopback: session order, late joiners and the volume,
// protocol violations (version, first message, oversize and undecodable frames, observers
// commanding, tokens, a second controller, a full server), disconnect and reconnect, a stalled
// client, the remote device, ping. Waits have generous timeouts; nothing gates on timing.
#include "net/server.hpp"

#include <poll.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <functional>
#include <thread>

#include "base/errors.hpp"
#include "net/protocol.hpp"
#include "support/net_test_client.hpp"
#include "support/palpd_test_util.hpp"
#include "wire/framing.hpp"

namespace palp::net {
namespace {

using testing::TestClient;
using Clock = std::chrono::steady_clock;

class TestControl final : public ControlTarget {
 public:
  TestControl(rt::HapticLoop& loop, rt::RemoteDevice& remote) : loop_(loop), remote_(remote) {}
  std::string set_tool(const std::string& tool) override {
    loop_.swap_model(std::make_shared<const Model>(loop_.model()->fields_ptr(), parse_tool(tool)));
    return {};
  }
  std::string set_parameter(const std::string& name, double value) override {
    ForceParams p = loop_.model()->params();
    set_param(p, name, value);
    loop_.swap_model(
        std::make_shared<const Model>(loop_.model()->fields_ptr(), loop_.model()->tool(), p));
    return {};
  }
  std::string set_paused(bool paused) override {
    loop_.set_paused(paused);
    return {};
  }
  std::string recentre() override {
    ++recentres;
    return "the remote device moves in the scene frame";
  }
  int recentres = 0;
  std::string start_recording(const std::string&, const std::string&) override {
    return "not in this test";
  }
  std::string stop_recording() override { return "not recording"; }
  bool recording() const override { return false; }
  std::uint64_t record_lost() const override { return 0; }
  bool set_device_pose(const Pose& pose, std::int64_t received_ns) override {
    remote_.submit(pose, received_ns);
    return true;
  }

 private:
  rt::HapticLoop& loop_;
  rt::RemoteDevice& remote_;
};

class ServerTest : public ::testing::Test {
 protected:
  void start(ServerConfig config = {}) {
    model_ = testing::ball_model("finger:7");
    rt::DeviceConfig dc;
    dc.timeout_s = 10.0;
    remote_.configure(dc);
    remote_.activate();
    rt::LoopConfig lc;
    lc.realtime = false;
    lc.watchdog_late_s = 0;
    lc.device_timeout_s = 0;
    loop_ = std::make_unique<rt::HapticLoop>(model_, remote_, lc);
    control_ = std::make_unique<TestControl>(*loop_, remote_);
    SceneDescription scene;
    scene.source = "ball";
    scene.grid = model_->fields().grid();
    scene.metadata = {{"kind", "test"}};
    scene.device = "remote";
    scene.fields = model_->fields_ptr();
    config.port = 0;
    if (config.volume_chunk_bytes == (1u << 20)) config.volume_chunk_bytes = 4096;
    server_ = std::make_unique<Server>(config, scene, *loop_, control_.get());
    loop_->start();
    server_->start();
  }
  void TearDown() override {
    if (server_) server_->stop();
    if (loop_) loop_->stop();
  }
  bool wait_clients(std::size_t n, double timeout_s = 10.0) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
    while (Clock::now() < deadline) {
      if (server_->client_count() == n) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }
  std::uint16_t port() const { return server_->port(); }

  std::shared_ptr<const Model> model_;
  rt::RemoteDevice remote_;
  std::unique_ptr<rt::HapticLoop> loop_;
  std::unique_ptr<TestControl> control_;
  std::unique_ptr<Server> server_;
};

void expect_fatal(TestClient& c, v1::Error::Code code) {
  v1::ServerMessage m;
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kError, m));
  EXPECT_EQ(m.error().code(), code) << m.error().reason();
  EXPECT_TRUE(m.error().fatal());
  EXPECT_FALSE(m.error().reason().empty());
  EXPECT_TRUE(c.closed_by_server());
}

TEST_F(ServerTest, ObserverGetsWelcomeSceneThenFrames) {
  start();
  TestClient c(port());
  c.hello();
  v1::ServerMessage m;
  ASSERT_TRUE(c.next(m));
  ASSERT_TRUE(m.has_welcome());
  EXPECT_EQ(m.welcome().protocol_version(), 1u);
  EXPECT_EQ(m.welcome().role(), v1::OBSERVER);
  EXPECT_EQ(m.welcome().tick_rate_hz(), 1000.0);
  ASSERT_TRUE(c.next(m));
  ASSERT_TRUE(m.has_scene());
  EXPECT_EQ(m.scene().source(), "ball");
  EXPECT_EQ(m.scene().grid().dims(0), 32);
  EXPECT_EQ(m.scene().grid().spacing(2), 2.0);
  EXPECT_EQ(m.scene().tool().name(), "finger:7");
  EXPECT_EQ(m.scene().tool().points_size(), 7);
  EXPECT_EQ(m.scene().parameters().c(), 2.0);
  EXPECT_EQ(m.scene().parameters().k(), 0.4);
  EXPECT_EQ(m.scene().metadata().at("kind"), "test");
  std::uint64_t last_seq = 0;
  std::int64_t last_t = 0;
  for (int i = 0; i < 50; ++i) {
    ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kFrame, m));
    if (i > 0) {
      EXPECT_GT(m.frame().seq(), last_seq);
      EXPECT_GT(m.frame().server_time_ns(), last_t);
    }
    last_seq = m.frame().seq();
    last_t = m.frame().server_time_ns();
    EXPECT_EQ(m.frame().fault(), rt::kZeroNoPose);  // no controller has moved the device yet
    EXPECT_EQ(m.frame().contact_points(), 7u);
    EXPECT_EQ(m.frame().contacts_size(), 0);
  }
}

TEST_F(ServerTest, LateJoinerGetsSceneAndVolumeBeforeFrames) {
  start();
  TestClient first(port());
  first.hello();
  v1::ServerMessage m;
  ASSERT_TRUE(first.wait_for_case(v1::ServerMessage::kFrame, m));
  TestClient late(port());
  late.hello(v1::OBSERVER, "", kProtocolVersion, 16);
  ASSERT_TRUE(late.next(m));
  ASSERT_TRUE(m.has_welcome());
  ASSERT_TRUE(late.next(m));
  ASSERT_TRUE(m.has_scene());
  // The force so far (the loop ran while the first client got its frames): ForceHistory.
  ASSERT_TRUE(late.next(m));
  ASSERT_TRUE(m.has_history());
  EXPECT_GT(m.history().server_time_ns_size(), 0);
  EXPECT_EQ(m.history().fx_size(), m.history().server_time_ns_size());
  EXPECT_DOUBLE_EQ(m.history().interval_s(), 0.02);
  // 32^3 at step 2 -> 16^3; 4096-byte chunks hold 2 slices of 16 x 16 x (d_surf, d_bone)
  // floats: 8 chunks.
  const FieldSampler& fields = model_->fields();
  for (std::uint32_t chunk = 0; chunk < 8; ++chunk) {
    ASSERT_TRUE(late.next(m));
    ASSERT_TRUE(m.has_volume()) << "chunk " << chunk << " came after a " << m.msg_case();
    const v1::VolumeChunk& v = m.volume();
    EXPECT_EQ(v.chunk_index(), chunk);
    EXPECT_EQ(v.chunk_count(), 8u);
    EXPECT_EQ(v.step(), 2u);
    EXPECT_EQ(v.dims(0), 16);
    EXPECT_EQ(v.spacing(0), 4.0);
    EXPECT_EQ(v.k_begin(), 2 * chunk);
    EXPECT_EQ(v.k_count(), 2u);
    ASSERT_EQ(v.d_surf().size(), 16u * 16u * 2u * sizeof(float));
    ASSERT_EQ(v.d_bone().size(), v.d_surf().size());
    // Sampled voxel (i, j, k) = original voxel (2i, 2j, 2(k_begin + k)).
    float value;
    const std::size_t at = (1 * 16 * 16 + 5 * 16 + 7) * sizeof(float);  // k = 1, j = 5, i = 7
    std::memcpy(&value, v.d_surf().data() + at, sizeof value);
    const Vec3d x{14.0 * 2, 10.0 * 2, (2.0 * (v.k_begin() + 1)) * 2};
    EXPECT_EQ(value, static_cast<float>(fields.sample_surf(x).value));
    std::memcpy(&value, v.d_bone().data() + at, sizeof value);
    EXPECT_EQ(value, static_cast<float>(fields.sample_bone(x).value));
  }
  ASSERT_TRUE(late.wait_for([](const v1::ServerMessage& s) { return !s.has_stats(); }, m));
  EXPECT_TRUE(m.has_frame());
}

TEST_F(ServerTest, VersionMismatchIsRefused) {
  start();
  TestClient c(port());
  c.hello(v1::OBSERVER, "", 2);
  expect_fatal(c, v1::Error::VERSION_MISMATCH);
  // The server is still serving.
  TestClient d(port());
  d.hello();
  v1::ServerMessage m;
  EXPECT_TRUE(d.wait_for_case(v1::ServerMessage::kFrame, m));
}

TEST_F(ServerTest, FirstMessageMustBeHello) {
  start();
  TestClient c(port());
  v1::ClientMessage ping;
  ping.mutable_ping()->set_id(1);
  c.send(ping);
  expect_fatal(c, v1::Error::EXPECTED_HELLO);
}

TEST_F(ServerTest, OversizeFrameIsRefusedFromItsPrefix) {
  ServerConfig config;
  config.max_frame_bytes = 1024;
  start(config);
  TestClient c(port());
  std::string prefix;
  std::uint8_t bytes[wire::kMaxVarintBytes];
  prefix.append(reinterpret_cast<const char*>(bytes), wire::encode_varint(1 << 20, bytes));
  c.send_raw(prefix);  // no body follows: the prefix alone is enough
  expect_fatal(c, v1::Error::FRAME_TOO_LARGE);
}

TEST_F(ServerTest, BadPrefixAndUndecodableEnvelopeBeforeHelloAreRefused) {
  start();
  TestClient c(port());
  c.send_raw(std::string(11, '\xff'));
  expect_fatal(c, v1::Error::MALFORMED);
  TestClient d(port());
  std::string frame;
  wire::append_frame(frame, "\xff\xff\xff\xff");
  d.send_raw(frame);
  expect_fatal(d, v1::Error::MALFORMED);
}

TEST_F(ServerTest, UndecodableMessageAfterHelloIsAnErrorNotADisconnect) {
  start();
  TestClient c(port());
  c.hello();
  v1::ServerMessage m;
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kFrame, m));
  std::string frame;
  wire::append_frame(frame, "\x0a\xff\xff");
  c.send_raw(frame);
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kError, m));
  EXPECT_EQ(m.error().code(), v1::Error::MALFORMED);
  EXPECT_FALSE(m.error().fatal());
  EXPECT_TRUE(c.wait_for_case(v1::ServerMessage::kFrame, m));
}

TEST_F(ServerTest, ObserversCannotCommandOrDrive) {
  start();
  TestClient c(port());
  c.hello();
  v1::ClientMessage cmd;
  cmd.mutable_command()->set_request_id(9);
  cmd.mutable_command()->mutable_pause()->set_paused(true);
  c.send(cmd);
  v1::ServerMessage m;
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kError, m));
  EXPECT_EQ(m.error().code(), v1::Error::PERMISSION_DENIED);
  EXPECT_FALSE(m.error().fatal());
  EXPECT_FALSE(loop_->paused());
  v1::ClientMessage pose;
  pose.mutable_device_pose()->mutable_pose()->mutable_position()->set_x(1);
  c.send(pose);
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kError, m));
  EXPECT_EQ(m.error().code(), v1::Error::PERMISSION_DENIED);
  EXPECT_TRUE(c.wait_for_case(v1::ServerMessage::kFrame, m));
}

TEST_F(ServerTest, ControllerNeedsTheTokenAndCommands) {
  ServerConfig config;
  config.token = "s3cret";
  start(config);
  TestClient wrong(port());
  wrong.hello(v1::CONTROLLER, "guess");
  expect_fatal(wrong, v1::Error::UNAUTHORIZED);
  TestClient c(port());
  c.hello(v1::CONTROLLER, "s3cret");
  v1::ServerMessage m;
  ASSERT_TRUE(c.next(m));
  ASSERT_TRUE(m.has_welcome());
  EXPECT_EQ(m.welcome().role(), v1::CONTROLLER);
  // A second controller is refused while this one is connected.
  TestClient second(port());
  second.hello(v1::CONTROLLER, "s3cret");
  expect_fatal(second, v1::Error::CONTROLLER_BUSY);
  // An observer sees the tool change too.
  TestClient watcher(port());
  watcher.hello();
  ASSERT_TRUE(watcher.wait_for_case(v1::ServerMessage::kFrame, m));

  v1::ClientMessage cmd;
  cmd.mutable_command()->set_request_id(1);
  cmd.mutable_command()->mutable_set_tool()->set_tool("finger:19");
  c.send(cmd);
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kResult, m));
  EXPECT_EQ(m.result().request_id(), 1u);
  EXPECT_TRUE(m.result().ok()) << m.result().message();
  ASSERT_TRUE(watcher.wait_for_case(v1::ServerMessage::kScene, m));
  EXPECT_EQ(m.scene().tool().name(), "finger:19");
  ASSERT_TRUE(watcher.wait_for(
      [](const v1::ServerMessage& s) { return s.has_frame() && s.frame().contact_points() == 19; },
      m));

  cmd.mutable_command()->set_request_id(2);
  cmd.mutable_command()->mutable_set_tool()->set_tool("hammer");
  c.send(cmd);
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kResult, m));
  EXPECT_EQ(m.result().request_id(), 2u);
  EXPECT_FALSE(m.result().ok());
  EXPECT_NE(m.result().message().find("hammer"), std::string::npos);

  cmd.mutable_command()->set_request_id(3);
  cmd.mutable_command()->mutable_set_parameter()->set_name("k");
  cmd.mutable_command()->mutable_set_parameter()->set_value(0.25);
  c.send(cmd);
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kResult, m));
  EXPECT_TRUE(m.result().ok()) << m.result().message();
  EXPECT_EQ(loop_->model()->params().k, 0.25);

  // Over the wire too, a parameter outside its physical range is refused.
  cmd.mutable_command()->set_request_id(6);
  cmd.mutable_command()->mutable_set_parameter()->set_name("k");
  cmd.mutable_command()->mutable_set_parameter()->set_value(50.0);
  c.send(cmd);
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kResult, m));
  EXPECT_FALSE(m.result().ok());
  EXPECT_NE(m.result().message().find("[0, 5] N/mm"), std::string::npos) << m.result().message();
  EXPECT_EQ(loop_->model()->params().k, 0.25);

  // Recentre reaches the control target, and its refusal comes back as the result.
  cmd.mutable_command()->set_request_id(5);
  cmd.mutable_command()->mutable_recentre();
  c.send(cmd);
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kResult, m));
  EXPECT_EQ(m.result().request_id(), 5u);
  EXPECT_FALSE(m.result().ok());
  EXPECT_NE(m.result().message().find("scene frame"), std::string::npos) << m.result().message();
  EXPECT_EQ(control_->recentres, 1);

  cmd.mutable_command()->set_request_id(4);
  cmd.mutable_command()->mutable_pause()->set_paused(true);
  c.send(cmd);
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kResult, m));
  EXPECT_TRUE(m.result().ok());
  ASSERT_TRUE(watcher.wait_for(
      [](const v1::ServerMessage& s) {
        return s.has_frame() && (s.frame().fault() & rt::kZeroPaused);
      },
      m));
}

TEST_F(ServerTest, ControllerDrivesTheRemoteDevice) {
  start();
  TestClient c(port());
  c.hello(v1::CONTROLLER);
  v1::ClientMessage pose;
  const Pose p = testing::press_pose(2.0);
  wire::to_proto(p, pose.mutable_device_pose()->mutable_pose());
  c.send(pose);
  v1::ServerMessage m;
  ASSERT_TRUE(c.wait_for(
      [](const v1::ServerMessage& s) { return s.has_frame() && s.frame().fault() == 0; }, m));
  EXPECT_EQ(wire::from_proto(m.frame().device_pose()).position, p.position);
  EXPECT_EQ(m.frame().n_contact(), 7u);
  EXPECT_GT(m.frame().force().z(), 0.0);  // pushed out of the ball's top
}

TEST_F(ServerTest, FullServerRefusesMoreClients) {
  ServerConfig config;
  config.max_clients = 1;
  start(config);
  TestClient a(port());
  a.hello();
  v1::ServerMessage m;
  ASSERT_TRUE(a.wait_for_case(v1::ServerMessage::kFrame, m));
  TestClient b(port());
  b.hello();
  expect_fatal(b, v1::Error::TOO_MANY_CLIENTS);
  EXPECT_TRUE(a.wait_for_case(v1::ServerMessage::kFrame, m));
  // The controller's slot is kept: a full server of observers still admits it.
  TestClient c(port());
  c.hello(v1::CONTROLLER);
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kWelcome, m));
  EXPECT_EQ(m.welcome().role(), v1::CONTROLLER);
}

// Guessing the token costs time: after three wrong tokens an address waits (100 ms, doubling),
// whatever it sends; once the wait is over the right token is accepted again.
TEST_F(ServerTest, WrongTokensBackOff) {
  ServerConfig config;
  config.token = "s3cret";
  start(config);
  v1::ServerMessage m;
  for (int i = 0; i < 3; ++i) {
    TestClient guess(port());
    guess.hello(v1::CONTROLLER, "guess" + std::to_string(i));
    ASSERT_TRUE(guess.wait_for_case(v1::ServerMessage::kError, m));
    EXPECT_EQ(m.error().reason(), "CONTROLLER needs the server's token: the one given is wrong");
  }
  TestClient hurried(port());
  hurried.hello(v1::CONTROLLER, "s3cret");  // even the right token waits now
  ASSERT_TRUE(hurried.wait_for_case(v1::ServerMessage::kError, m));
  EXPECT_EQ(m.error().code(), v1::Error::UNAUTHORIZED);
  EXPECT_NE(m.error().reason().find("too many wrong tokens"), std::string::npos)
      << m.error().reason();
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  TestClient patient(port());
  patient.hello(v1::CONTROLLER, "s3cret");
  ASSERT_TRUE(patient.wait_for_case(v1::ServerMessage::kWelcome, m));
}

// Sockets that never say Hello have a budget of their own (per address and in all): they cannot
// fill max_clients and lock observers and the controller out.
TEST_F(ServerTest, SilentSocketsCannotLockClientsOut) {
  ServerConfig config;
  config.max_clients = 2;
  config.max_pending_per_address = 3;
  config.hello_timeout_s = 30;  // they stay for the whole test
  start(config);
  std::vector<std::unique_ptr<TestClient>> silent;
  for (int i = 0; i < 3; ++i) silent.push_back(std::make_unique<TestClient>(port()));
  TestClient over(port());  // a fourth from the same address: refused at once
  expect_fatal(over, v1::Error::TOO_MANY_CLIENTS);
  for (auto& c : silent) c->close();  // the pending budget frees as they go
  ASSERT_TRUE(wait_clients(0));
  TestClient a(port()), b(port());
  a.hello();
  b.hello();
  v1::ServerMessage m;
  ASSERT_TRUE(a.wait_for_case(v1::ServerMessage::kFrame, m));
  ASSERT_TRUE(b.wait_for_case(v1::ServerMessage::kFrame, m));
  std::vector<std::unique_ptr<TestClient>> more;
  for (int i = 0; i < 2; ++i) more.push_back(std::make_unique<TestClient>(port()));  // silent
  TestClient controller(port());
  controller.hello(v1::CONTROLLER);
  ASSERT_TRUE(controller.wait_for_case(v1::ServerMessage::kWelcome, m));
}

TEST_F(ServerTest, DisconnectAndReconnect) {
  start();
  {
    TestClient c(port());
    c.hello();
    v1::ServerMessage m;
    ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kFrame, m));
    EXPECT_EQ(server_->client_count(), 1u);
    c.close();
  }
  EXPECT_TRUE(wait_clients(0));
  TestClient again(port());
  again.hello();
  v1::ServerMessage m;
  ASSERT_TRUE(again.wait_for_case(v1::ServerMessage::kWelcome, m));
  EXPECT_EQ(m.welcome().client_id(), 2u);
  EXPECT_TRUE(again.wait_for_case(v1::ServerMessage::kFrame, m));
  EXPECT_TRUE(wait_clients(1));
}

TEST_F(ServerTest, StalledClientIsDroppedWithoutHoldingOthersUp) {
  ServerConfig config;
  config.send_buffer_bytes = 4096;
  config.queue_frames = 8;
  config.write_timeout_s = 0.3;
  start(config);
  TestClient stalled(port(), 4096);
  stalled.hello(v1::OBSERVER, "", kProtocolVersion, 0, 0.0, true);  // every tick, with contacts
  TestClient healthy(port());
  healthy.hello();
  v1::ServerMessage m;
  // The stalled client never reads: its queue overflows (oldest frames dropped), its socket stops
  // draining and it is closed; the healthy one keeps getting frames throughout.
  const auto deadline = Clock::now() + std::chrono::seconds(20);
  std::uint64_t frames = 0;
  while (Clock::now() < deadline && (server_->counters().timeouts == 0 || frames < 100)) {
    ASSERT_TRUE(healthy.wait_for_case(v1::ServerMessage::kFrame, m));
    ++frames;
  }
  EXPECT_GE(server_->counters().timeouts, 1u);
  EXPECT_GT(server_->counters().frames_dropped, 0u);
  EXPECT_TRUE(wait_clients(1));
  ASSERT_TRUE(healthy.wait_for_case(v1::ServerMessage::kFrame, m));
}

// Sends `batch` (many frames) until the server closes the connection.
void flood_until_closed(TestClient& c, const std::string& batch) {
  try {
    for (int n = 0; n < 100000; ++n) c.send_raw(batch);
  } catch (const std::exception&) {  // reset or broken pipe: the server dropped us
  }
}

// Two clients flood (Pings, and Commands an observer may not send) and never read. Without the
// write timeout, only the byte bound on their queues (pongs, errors) can stop them: each is
// dropped, while an observer that reads keeps getting frames.
TEST_F(ServerTest, FloodingClientsThatNeverReadAreDroppedByTheirQueueBound) {
  ServerConfig config;
  config.send_buffer_bytes = 4096;
  config.write_timeout_s = 0;
  config.idle_timeout_s = 0;
  config.max_queue_bytes = 256 << 10;
  start(config);
  TestClient healthy(port());
  healthy.hello();
  v1::ServerMessage m;
  ASSERT_TRUE(healthy.wait_for_case(v1::ServerMessage::kFrame, m));

  TestClient pinger(port(), 4096), commander(port(), 4096);
  pinger.hello(v1::OBSERVER, "", kProtocolVersion, 0, 1.0);
  commander.hello(v1::OBSERVER, "", kProtocolVersion, 0, 1.0);
  std::string pings, commands;
  for (int n = 0; n < 2000; ++n) {
    v1::ClientMessage ping;
    ping.mutable_ping()->set_id(static_cast<std::uint64_t>(n));
    pings += wire::encode_frame(ping);
    v1::ClientMessage command;
    command.mutable_command()->set_request_id(static_cast<std::uint64_t>(n));
    command.mutable_command()->mutable_pause()->set_paused(false);
    commands += wire::encode_frame(command);
  }
  std::thread ping_flood([&] { flood_until_closed(pinger, pings); });
  std::thread command_flood([&] { flood_until_closed(commander, commands); });

  const auto deadline = Clock::now() + std::chrono::seconds(20);
  std::uint64_t frames = 0;
  while (Clock::now() < deadline && (server_->counters().overflows < 2 || frames < 200)) {
    ASSERT_TRUE(healthy.wait_for_case(v1::ServerMessage::kFrame, m, 2.0));
    ++frames;
  }
  ping_flood.join();
  command_flood.join();
  EXPECT_EQ(server_->counters().overflows, 2u);
  EXPECT_TRUE(wait_clients(1));
  ASSERT_TRUE(healthy.wait_for_case(v1::ServerMessage::kFrame, m));
}

TEST_F(ServerTest, SilentConnectionTimesOut) {
  ServerConfig config;
  config.hello_timeout_s = 0.2;
  start(config);
  TestClient c(port());
  expect_fatal(c, v1::Error::TIMEOUT);
}

TEST_F(ServerTest, PingGetsPongAndStatsArrive) {
  ServerConfig config;
  config.stats_interval_s = 0.2;
  start(config);
  TestClient c(port());
  c.hello(v1::OBSERVER, "", kProtocolVersion, 0, 100.0);
  v1::ClientMessage ping;
  ping.mutable_ping()->set_id(77);
  ping.mutable_ping()->set_client_time_ns(5);
  c.send(ping);
  v1::ServerMessage m;
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kPong, m));
  EXPECT_EQ(m.pong().id(), 77u);
  EXPECT_EQ(m.pong().client_time_ns(), 5);
  ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kStats, m));
  EXPECT_EQ(m.stats().target_rate_hz(), 1000.0);
  EXPECT_EQ(m.stats().jitter_counts_size(), m.stats().jitter_bucket_upper_us_size() + 1);
  EXPECT_EQ(m.stats().wake_latency_counts_size(), m.stats().jitter_bucket_upper_us_size() + 1);
  EXPECT_EQ(m.stats().wake_mode(), "hybrid");  // the default
  EXPECT_GE(m.stats().clients(), 1u);
  EXPECT_GT(m.stats().ticks(), 0u);
}

TEST_F(ServerTest, RequestedFrameRateThinsTheStream) {
  start();
  TestClient c(port());
  c.hello(v1::OBSERVER, "", kProtocolVersion, 0, 100.0);  // 100 of the 1000 ticks a second
  // The schedule is drift-free (frame k is due at first + k * 10 ms), so a frame that had to wait
  // for a late tick is followed by a shorter gap: the client never gets more than its rate on
  // average, and a rate that is not a whole number of ticks is still met on average.
  v1::ServerMessage m;
  std::int64_t first = 0, last = 0;
  for (int i = 0; i < 10; ++i) {
    ASSERT_TRUE(c.wait_for_case(v1::ServerMessage::kFrame, m));
    const std::int64_t t = m.frame().server_time_ns();
    if (i == 0) {
      first = t;
    } else {
      EXPECT_GT(t, last);
      EXPECT_GE(t - first, i * 10'000'000LL - 1) << "frame " << i;
    }
    last = t;
  }
}

TEST(ServerSetup, RefusesABadBindAddress) {
  auto model = testing::ball_model();
  rt::RemoteDevice remote;
  rt::LoopConfig lc;
  lc.realtime = false;
  rt::HapticLoop loop(model, remote, lc);
  ServerConfig config;
  config.bind = "not-an-address";
  EXPECT_THROW(Server(config, {}, loop, nullptr), UsageError);
}

}  // namespace
}  // namespace palp::net
