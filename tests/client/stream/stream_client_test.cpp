// palpview's network layer (client/stream_client) end to end.
//
// Against the real palpd (started with posix_spawn so the test can SIGSTOP, SIGCONT and SIGKILL
// it; scenes prepped into a private PALP_SCENE_CACHE): scene and render volume (compared voxel
// for voxel with the prepped map), frames, Stalled and Live again, reconnection to a restarted
// server, refusal on a wrong token, the controller driving the `remote` device, command results.
// Against scripted fake servers on loopback: malformed volume chunks and frames drop the
// connection with a clear message, the Ping/Pong clock offset makes latency right for a server
// whose clock is 1000 s ahead, and the delivered fraction and device state come from Stats.
// Every wait is for a condition with a generous timeout; nothing gates on speed.
#include "stream/stream_client.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "asio.hpp"
#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "io/phantom.hpp"
#include "support/cli_test_util.hpp"
#include "wire/framing.hpp"
#include "wire/messages.hpp"
#include "wire/volume_codec.hpp"

extern char** environ;

namespace palp {
namespace {

namespace fs = std::filesystem;
namespace v1 = palp::v1;
using asio::ip::tcp;
using testing::read_text;
using testing::shared_cli_dir;
using view::LatestState;
using view::LinkState;
using view::StreamClient;
using view::StreamOptions;

constexpr double kTimeoutS = 30.0;  // generous: a loaded 2-core machine

// Polls latest() until `want` holds or `timeout_s` passes; returns the last state seen.
LatestState wait_for(const StreamClient& client,
                     const std::function<bool(const LatestState&)>& want,
                     double timeout_s = kTimeoutS) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  LatestState s = client.latest();
  while (!want(s) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    s = client.latest();
  }
  return s;
}

bool is_state(const LatestState& s, LinkState state) {
  return s.link.state == state;
}

// palpd as a child process, its output in a log file.
class Palpd {
 public:
  // Starts palpd with `args`; port() is 0 when it did not come up.
  Palpd(const std::vector<std::string>& args, const std::string& log_name)
      : log_(shared_cli_dir() / log_name) {
    ::setenv("PALP_SCENE_CACHE", (shared_cli_dir() / "cache").c_str(), 1);
    std::vector<std::string> all = {PALPD_PATH};
    all.insert(all.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 1, log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    const int rc = posix_spawn(&pid_, PALPD_PATH, &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) {
      pid_ = 0;
      return;
    }
    const std::regex listening("listening on 127\\.0\\.0\\.1:([0-9]+)");
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (std::chrono::steady_clock::now() < deadline) {
      std::smatch match;
      const std::string text = read_text(log_);
      if (std::regex_search(text, match, listening)) {
        port_ = static_cast<std::uint16_t>(std::stoi(match[1]));
        return;
      }
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = 0;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  ~Palpd() { kill(); }
  Palpd(const Palpd&) = delete;
  Palpd& operator=(const Palpd&) = delete;

  std::uint16_t port() const { return port_; }
  pid_t pid() const { return pid_; }
  std::string log() const { return read_text(log_); }
  void signal(int sig) const {
    if (pid_ > 0) ::kill(pid_, sig);
  }
  // SIGKILL and reap: the port is free once this returns.
  void kill() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGCONT);
    ::kill(pid_, SIGKILL);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = 0;
  }

 private:
  fs::path log_;
  pid_t pid_ = 0;
  std::uint16_t port_ = 0;
};

std::vector<std::string> palpd_args(const std::string& scene, const std::string& device,
                                    std::uint16_t port = 0) {
  return {"--scene", scene,  "--device",      device,       "--port", std::to_string(port),
          "--rate",  "1000", "--no-realtime", "--duration", "300"};
}

StreamOptions options_for(std::uint16_t port) {
  StreamOptions o;
  o.port = port;
  o.volume_max_dim = 32;
  o.stall_s = 0.3;
  o.reconnect_min_s = 0.05;
  o.reconnect_max_s = 0.4;
  return o;
}

TEST(StreamClient, RejectsUnusableOptions) {
  StreamOptions o;
  o.port = 0;
  EXPECT_THROW(StreamClient{o}, UsageError);
  o = StreamOptions{};
  o.stall_s = 0;
  EXPECT_THROW(StreamClient{o}, UsageError);
  o = StreamOptions{};
  o.reconnect_max_s = o.reconnect_min_s / 2;
  EXPECT_THROW(StreamClient{o}, UsageError);
  o = StreamOptions{};
  o.frame_rate_hz = -1;
  EXPECT_THROW(StreamClient{o}, UsageError);
  o = StreamOptions{};
  o.token = std::string(300, 't');
  EXPECT_THROW(StreamClient{o}, UsageError);
  EXPECT_STREQ(view::to_string(LinkState::Stalled), "stalled");
  EXPECT_STREQ(view::to_string(view::DeviceState::Absent), "absent");
}

// A token for another machine without TLS is never sent: the client goes Refused before it
// connects, naming --tls-ca and --tls-pin; to loopback, or without a token, it may connect. A
// certificate without TLS is refused when the client is made.
TEST(StreamClient, ATokenForAnotherMachineWithoutTlsIsRefusedBeforeConnecting) {
  StreamOptions o;
  o.host = "192.0.2.1";  // TEST-NET-1: nothing answers, a client that tried would keep trying
  o.controller = true;
  o.token = "s3cret";
  EXPECT_NE(connect_refusal(o).find("--tls-ca"), std::string::npos) << connect_refusal(o);
  StreamClient client(o);
  client.start();
  const LatestState s = wait_for(
      client, [](const LatestState& l) { return is_state(l, LinkState::Refused); }, 10.0);
  EXPECT_EQ(s.link.state, LinkState::Refused) << s.link.message;
  EXPECT_NE(s.link.message.find("clear text"), std::string::npos) << s.link.message;
  EXPECT_NE(s.link.message.find("--tls-pin"), std::string::npos) << s.link.message;
  EXPECT_EQ(s.link.connections, 0u);
  client.stop();
  o.host = "127.0.0.1";
  EXPECT_EQ(connect_refusal(o), "");
  o.host = "localhost";
  EXPECT_EQ(connect_refusal(o), "");
  o.host = "192.0.2.1";
  o.token.clear();
  EXPECT_EQ(connect_refusal(o), "");
  o.tls_cert = "station.crt";
  o.tls_key = "station.key";
  EXPECT_THROW(StreamClient{o}, UsageError);
}

// ------------------------------------------------------------------------------ against palpd

TEST(StreamClient, ReceivesSceneVolumeAndFramesFromPalpd) {
  Palpd palpd(palpd_args("phantom:sphere", "sim"), "scene.log");
  ASSERT_GT(palpd.port(), 0) << palpd.log();
  StreamClient client(options_for(palpd.port()));
  EXPECT_EQ(client.latest().link.state, LinkState::Connecting);
  client.start();
  LatestState s = wait_for(client, [](const LatestState& l) {
    return is_state(l, LinkState::Live) && l.volume && l.link.frames_per_s > 0;
  });
  ASSERT_EQ(s.link.state, LinkState::Live) << s.link.message;
  EXPECT_EQ(s.link.connections, 1u);
  EXPECT_EQ(s.connection, 1u);

  // The scene: the sphere phantom's grid, palpd's default tool.
  ASSERT_TRUE(s.scene);
  const Grid grid = phantom_grid("sphere");
  EXPECT_EQ(s.scene->source, "phantom:sphere");
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(s.scene->dims[a], grid.dims[a]);
    EXPECT_EQ(s.scene->spacing[a], grid.spacing[a]);
  }
  EXPECT_EQ(s.scene->tool, "finger:37");
  EXPECT_EQ(s.scene->tool_points.size(), 37u);
  EXPECT_EQ(s.scene->device, "sim");
  EXPECT_EQ(s.scene->tick_rate_hz, 1000.0);
  EXPECT_EQ(s.scene->server_name, "palpd");

  // The volume: cropped to the body's box (Hello.volume_crop; the sphere phantom's body leaves
  // little air), at the step that keeps the box within 32 a side, at the prepped map's values
  // exactly, each voxel at origin + (i, j, k) * spacing.
  ASSERT_TRUE(s.volume);
  const view::RenderVolume& v = *s.volume;
  EXPECT_LE(v.step, 4u);
  std::array<std::int64_t, 3> offset{};
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(v.dims[a], 32);
    EXPECT_EQ(v.spacing[a], v.step * grid.spacing[a]);
    offset[a] = std::llround(v.origin[a] / grid.spacing[a]);
    EXPECT_DOUBLE_EQ(v.origin[a], static_cast<double>(offset[a]) * grid.spacing[a]);
    EXPECT_GE(offset[a], 0);
    EXPECT_LE(offset[a] + (v.dims[a] - 1) * v.step, grid.dims[a] - 1);
  }
  const std::size_t n = static_cast<std::size_t>(v.dims[0] * v.dims[1] * v.dims[2]);
  ASSERT_EQ(v.d_surf.size(), n);
  EXPECT_TRUE(v.d_bone.empty() || v.d_bone.size() == v.d_surf.size());
  EXPECT_EQ(s.link.volume_progress, 1.0);
  ASSERT_EQ(s.scene->metadata.count("prep_dir"), 1u);
  const DistanceMap d_surf = read_nifti_float(s.scene->metadata.at("prep_dir") + "/d_surf.nii.gz");
  std::size_t mismatches = 0, inside = 0;
  const std::int64_t st = v.step;
  for (std::int64_t k = 0; k < v.dims[2]; ++k)
    for (std::int64_t j = 0; j < v.dims[1]; ++j)
      for (std::int64_t i = 0; i < v.dims[0]; ++i) {
        const float got = v.d_surf[static_cast<std::size_t>((k * v.dims[1] + j) * v.dims[0] + i)];
        mismatches += got != d_surf.at(offset[0] + st * i, offset[1] + st * j, offset[2] + st * k);
        inside += got > 0;
      }
  EXPECT_EQ(mismatches, 0u);
  EXPECT_GT(inside, 100u);  // the ball (radius 30 mm) is in it

  // Frames with their contacts, a force history, and the link figures.
  ASSERT_TRUE(s.frame.valid);
  EXPECT_EQ(s.frame.contact_points, 37u);
  EXPECT_EQ(s.frame.contacts.size(), 37u);
  EXPECT_GT(s.link.frames, 0u);
  s = wait_for(client, [](const LatestState& l) {
    return l.link.delivered >= 0 && l.link.latency_ms >= 0 && l.force_history.size() > 10;
  });
  EXPECT_GT(s.link.delivered, 0.0);
  EXPECT_LE(s.link.delivered, 1.0);
  // Same host, same CLOCK_MONOTONIC: the true offset is 0, and the estimate is off by at most
  // half the round trip it came from.
  ASSERT_GE(s.link.rtt_ms, 0.0);
  EXPECT_LE(std::abs(s.link.clock_offset_ms), s.link.rtt_ms / 2 + 1e-6);
  EXPECT_GE(s.link.latency_ms, -s.link.rtt_ms / 2 - 1e-6);
  ASSERT_GT(s.force_history.size(), 10u);
  for (std::size_t i = 1; i < s.force_history.size(); ++i)
    ASSERT_GT(s.force_history[i].t_s, s.force_history[i - 1].t_s);
  EXPECT_LE(s.force_history.back().t_s - s.force_history.front().t_s, 10.0);
  // The sim device is always there (Unknown from a palpd that does not fill device_state yet).
  for (const view::DeviceState d : {s.link.device_state, s.frame.device_state})
    EXPECT_TRUE(d == view::DeviceState::Present || d == view::DeviceState::Unknown)
        << view::to_string(d);
  client.stop();
  client.stop();  // idempotent
}

TEST(StreamClient, StalledWhileThePalpdProcessIsStoppedAndLiveAfterwards) {
  Palpd palpd(palpd_args("phantom:sphere", "sim"), "stall.log");
  ASSERT_GT(palpd.port(), 0) << palpd.log();
  StreamOptions o = options_for(palpd.port());
  o.volume_max_dim = 0;
  StreamClient client(o);
  client.start();
  LatestState s =
      wait_for(client, [](const LatestState& l) { return is_state(l, LinkState::Live); });
  ASSERT_EQ(s.link.state, LinkState::Live) << s.link.message;
  EXPECT_FALSE(s.volume);  // not asked for
  EXPECT_EQ(s.link.volume_progress, 1.0);

  palpd.signal(SIGSTOP);
  s = wait_for(client, [](const LatestState& l) { return is_state(l, LinkState::Stalled); });
  EXPECT_EQ(s.link.state, LinkState::Stalled) << s.link.message;
  EXPECT_NE(s.link.message.find("no frame for"), std::string::npos) << s.link.message;
  EXPECT_GE(s.link.since_last_frame_s, o.stall_s);
  const std::uint64_t frames = s.link.frames;

  palpd.signal(SIGCONT);
  s = wait_for(client, [&](const LatestState& l) {
    return is_state(l, LinkState::Live) && l.link.frames > frames;
  });
  EXPECT_EQ(s.link.state, LinkState::Live) << s.link.message;
  EXPECT_EQ(s.link.connections, 1u);  // the same connection came back
  EXPECT_LT(s.link.since_last_frame_s, 5.0);
}

// A station that joins after the loop ran gets palpd's force history (server/net/force_history):
// its chart starts with the seconds before it came (t < 0), one sample every 20 ms, the forces
// those a station present from the start received for the same ticks.
TEST(StreamClient, ALateJoinerGetsTheSessionsForceHistory) {
  Palpd palpd(palpd_args("phantom:sphere", "sim"), "history.log");
  ASSERT_GT(palpd.port(), 0) << palpd.log();
  StreamOptions early_opts = options_for(palpd.port());
  early_opts.frame_rate_hz = 0;              // every tick
  early_opts.force_history_max_samples = 0;  // none thinned
  early_opts.volume_max_dim = 0;             // frames at once
  StreamClient early(early_opts);
  early.start();
  LatestState e =
      wait_for(early, [](const LatestState& l) { return l.force_history.size() > 2000; });
  ASSERT_GT(e.force_history.size(), 2000u);  // 2 s of ticks seen from the start
  StreamOptions late_opts = options_for(palpd.port());
  late_opts.force_history_s = 10.0;
  StreamClient late(late_opts);
  late.start();
  LatestState l = wait_for(late, [](const LatestState& s) { return s.frame.valid; });
  ASSERT_TRUE(l.frame.valid);
  e = early.latest();
  std::vector<view::ForceSample> before;
  for (const view::ForceSample& s : l.force_history)
    if (s.t_s < 0) before.push_back(s);
  // About the 2 s the loop ran before, every 20 ms.
  ASSERT_GT(before.size(), 80u);
  EXPECT_LE(before.size(), 501u);
  // Every 20 ms of what the network thread saw: never closer, and a longer gap only where no
  // frame came in between (the loop's ring to the network thread dropped them on a loaded
  // machine) — the early station, sent every frame the network thread handled, saw none there.
  for (std::size_t i = 1; i < before.size(); ++i) {
    const std::int64_t a = before[i - 1].server_time_ns, b = before[i].server_time_ns;
    EXPECT_GE(b - a, 20'000'000);
    for (const view::ForceSample& r : e.force_history)
      EXPECT_FALSE(r.server_time_ns >= a + 20'000'000 && r.server_time_ns < b)
          << "a frame at " << r.server_time_ns << " between history samples " << a << " and " << b;
  }
  // The same ticks' forces as the early station's frames.
  std::size_t matched = 0;
  for (const view::ForceSample& s : before)
    for (const view::ForceSample& r : e.force_history)
      if (r.server_time_ns == s.server_time_ns) {
        EXPECT_EQ(r.force, s.force);
        ++matched;
        break;
      }
  EXPECT_GT(matched, before.size() / 2);
  bool pressed = false;
  for (const view::ForceSample& s : before) pressed = pressed || norm(s.force) > 0.1;
  EXPECT_TRUE(pressed);  // the sim device presses the ball: not a history of zeros
}

TEST(StreamClient, ReconnectsToARestartedPalpdAndTakesItsNewScene) {
  auto first = std::make_unique<Palpd>(palpd_args("phantom:sphere", "sim"), "first.log");
  ASSERT_GT(first->port(), 0) << first->log();
  const std::uint16_t port = first->port();
  StreamOptions opts = options_for(port);
  opts.volume_crop = false;  // the whole grid, whose size is known
  StreamClient client(opts);
  client.start();
  LatestState s = wait_for(
      client, [](const LatestState& l) { return is_state(l, LinkState::Live) && l.volume; });
  ASSERT_EQ(s.link.state, LinkState::Live) << s.link.message;
  EXPECT_EQ(s.scene->source, "phantom:sphere");

  first->kill();
  s = wait_for(client, [](const LatestState& l) { return is_state(l, LinkState::Reconnecting); });
  EXPECT_EQ(s.link.state, LinkState::Reconnecting);
  EXPECT_NE(s.link.message.find("retrying in"), std::string::npos) << s.link.message;
  EXPECT_EQ(s.connection, 1u);  // the old scene stays until the next Welcome
  EXPECT_TRUE(s.scene);

  Palpd second(palpd_args("phantom:cube", "sim", port), "second.log");
  ASSERT_EQ(second.port(), port) << second.log();
  s = wait_for(client, [](const LatestState& l) {
    return is_state(l, LinkState::Live) && l.link.connections == 2 && l.volume;
  });
  ASSERT_EQ(s.link.state, LinkState::Live) << s.link.message;
  EXPECT_EQ(s.link.connections, 2u);
  EXPECT_EQ(s.connection, 2u);
  ASSERT_TRUE(s.scene);
  EXPECT_EQ(s.scene->source, "phantom:cube");
  const Grid cube = phantom_grid("cube");
  EXPECT_EQ(s.scene->dims[0], cube.dims[0]);
  // ceil(140 / 32) = 5: 28 samples per axis.
  EXPECT_EQ(s.volume->step, 5u);
  EXPECT_EQ(s.volume->dims[2], 28);
}

TEST(StreamClient, WrongTokenIsRefusedWithoutRetrying) {
  std::vector<std::string> args = palpd_args("phantom:sphere", "remote");
  args.insert(args.end(), {"--token", "letmein"});
  Palpd palpd(args, "token.log");
  ASSERT_GT(palpd.port(), 0) << palpd.log();
  StreamOptions o = options_for(palpd.port());
  o.controller = true;
  o.token = "wrong";
  StreamClient client(o);
  client.start();
  LatestState s =
      wait_for(client, [](const LatestState& l) { return is_state(l, LinkState::Refused); });
  ASSERT_EQ(s.link.state, LinkState::Refused) << s.link.message;
  EXPECT_NE(s.link.message.find("UNAUTHORIZED"), std::string::npos) << s.link.message;
  EXPECT_NE(s.link.message.find("token"), std::string::npos) << s.link.message;
  EXPECT_EQ(s.link.connections, 0u);
  // No retry: well past several backoff periods it is still refused, and the server saw one
  // client.
  std::this_thread::sleep_for(std::chrono::milliseconds(800));
  s = client.latest();
  EXPECT_EQ(s.link.state, LinkState::Refused);
  EXPECT_EQ(s.link.connections, 0u);
  EXPECT_EQ(client.set_paused(true), 1u);  // refused locally: not connected
  s = client.latest();
  EXPECT_EQ(s.link.last_request_id, 1u);
  EXPECT_FALSE(s.link.last_result_ok);
  EXPECT_NE(s.link.last_result_message.find("not connected"), std::string::npos);
  client.stop();
  palpd.signal(SIGTERM);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (palpd.log().find(" ticks, ") == std::string::npos &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_NE(palpd.log().find("1 clients served"), std::string::npos) << palpd.log();

  // The right token gets in.
  Palpd again(args, "token2.log");
  ASSERT_GT(again.port(), 0) << again.log();
  o.port = again.port();
  o.token = "letmein";
  StreamClient good(o);
  good.start();
  s = wait_for(good, [](const LatestState& l) { return is_state(l, LinkState::Live); });
  EXPECT_EQ(s.link.state, LinkState::Live) << s.link.message;
}

TEST(StreamClient, ControllerDrivesTheRemoteDeviceAndGetsCommandResults) {
  Palpd palpd(palpd_args("phantom:sphere", "remote"), "remote.log");
  ASSERT_GT(palpd.port(), 0) << palpd.log();
  StreamOptions o = options_for(palpd.port());
  o.controller = true;
  o.volume_max_dim = 0;
  StreamClient client(o);
  // An observer's controls do nothing.
  StreamClient observer(options_for(palpd.port()));
  EXPECT_EQ(observer.set_tool("finger:7"), 0u);
  client.start();
  LatestState s =
      wait_for(client, [](const LatestState& l) { return is_state(l, LinkState::Live); });
  ASSERT_EQ(s.link.state, LinkState::Live) << s.link.message;
  EXPECT_EQ(s.scene->device, "remote");

  // The pose sent comes back in the frames, bit for bit; pressing 2 mm into the top of the ball
  // (the pad is 8 mm below the device point) gives contact and an outward (+z) force.
  const SphereGeometry ball = sphere_geometry(phantom_grid("sphere"));
  Pose press;
  press.position = {ball.centre[0], ball.centre[1], ball.centre[2] + ball.radius + 8.0 - 2.0};
  const auto drive = [&](const Pose& pose, const std::function<bool(const LatestState&)>& want) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    LatestState l = client.latest();
    while (std::chrono::steady_clock::now() < deadline) {
      client.send_pose(pose);
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      l = client.latest();
      if (l.frame.valid && l.frame.pose.position == pose.position && want(l)) break;
    }
    return l;
  };
  s = drive(press, [](const LatestState& l) { return l.frame.n_contact > 0; });
  EXPECT_EQ(s.frame.pose.position, press.position);
  EXPECT_GT(s.frame.n_contact, 0u);
  EXPECT_GT(s.frame.force.z, 0.0);
  Pose away = press;
  away.position.z += 30.0;
  s = drive(away, [](const LatestState&) { return true; });
  EXPECT_EQ(s.frame.pose.position, away.position);
  EXPECT_EQ(s.frame.n_contact, 0u);

  const auto result = [&](std::uint64_t id) {
    return wait_for(client, [id](const LatestState& l) { return l.link.last_request_id == id; });
  };
  std::uint64_t id = client.set_parameter("k", 0.3);
  EXPECT_EQ(id, 1u);
  s = result(id);
  EXPECT_TRUE(s.link.last_result_ok) << s.link.last_result_message;
  s = wait_for(client, [](const LatestState& l) { return l.scene && l.scene->k == 0.3; });
  EXPECT_EQ(s.scene->k, 0.3);

  id = client.set_tool("finger:7");
  s = result(id);
  EXPECT_TRUE(s.link.last_result_ok) << s.link.last_result_message;
  s = wait_for(client, [](const LatestState& l) { return l.scene && l.scene->tool == "finger:7"; });
  EXPECT_EQ(s.scene->tool_points.size(), 7u);
  EXPECT_EQ(s.connection, 1u);  // a new SceneInfo, the same connection

  id = client.set_parameter("no_such_parameter", 1.0);
  s = result(id);
  EXPECT_FALSE(s.link.last_result_ok);
  EXPECT_FALSE(s.link.last_result_message.empty());

  id = client.set_parameter("k", std::nan(""));  // refused before it is sent
  s = client.latest();
  EXPECT_EQ(s.link.last_request_id, id);
  EXPECT_FALSE(s.link.last_result_ok);
  EXPECT_NE(s.link.last_result_message.find("finite"), std::string::npos);

  id = client.set_paused(true);
  s = result(id);
  EXPECT_TRUE(s.link.last_result_ok) << s.link.last_result_message;
  s = wait_for(client, [](const LatestState& l) { return l.link.server_paused; });
  EXPECT_TRUE(s.link.server_paused);
  s = result(client.set_paused(false));
  EXPECT_TRUE(s.link.last_result_ok);

  // Recording commands reach palpd (a path-like name is refused there, writing nothing; stop
  // without a recording is refused too): palpview's O key sends these.
  s = result(client.start_recording("../escape"));
  EXPECT_FALSE(s.link.last_result_ok);
  EXPECT_NE(s.link.last_result_message.find("plain file name"), std::string::npos)
      << s.link.last_result_message;
  s = result(client.stop_recording());
  EXPECT_FALSE(s.link.last_result_ok);
  EXPECT_NE(s.link.last_result_message.find("not recording"), std::string::npos)
      << s.link.last_result_message;
}

// ------------------------------------------------------------------------------ fake servers

// One scripted palp.v1 server connection on loopback, run on its own thread.
class FakeServer {
 public:
  class Session {
   public:
    explicit Session(tcp::socket socket)
        : socket_(std::move(socket)), decoder_(wire::kDefaultMaxClientFrame) {}
    void send(const v1::ServerMessage& m) { send_raw(wire::encode_frame(m)); }
    void send_raw(const std::string& bytes) {
      asio::error_code ec;
      asio::write(socket_, asio::buffer(bytes), ec);
    }
    // Client messages arriving within `timeout_s` go to `on`; false once the client closed.
    bool receive(double timeout_s, const std::function<void(const v1::ClientMessage&)>& on) {
      pollfd p{socket_.native_handle(), POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(timeout_s * 1000)) <= 0) return !closed_;
      std::array<std::uint8_t, 4096> buffer{};
      asio::error_code ec;
      const std::size_t n = socket_.read_some(asio::buffer(buffer), ec);
      if (ec) {
        closed_ = true;
        return false;
      }
      decoder_.feed(buffer.data(), n);
      std::string_view body;
      v1::ClientMessage m;
      while (decoder_.next(body) == wire::FrameStatus::Ok)
        if (m.ParseFromArray(body.data(), static_cast<int>(body.size()))) on(m);
      return true;
    }
    // Waits for the Hello; false when none came.
    bool hello() {
      bool got = false;
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
      while (!got && std::chrono::steady_clock::now() < deadline)
        if (!receive(0.05, [&](const v1::ClientMessage& m) { got = got || m.has_hello(); }))
          return false;
      return got;
    }
    bool closed() const { return closed_; }

   private:
    tcp::socket socket_;
    wire::FrameDecoder decoder_;
    bool closed_ = false;
  };

  // Serves one connection with `script`, then keeps reading until the client hangs up or the
  // test ends.
  explicit FakeServer(std::function<void(Session&, const std::atomic<bool>& stop)> script)
      : acceptor_(io_, tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0)) {
    acceptor_.non_blocking(true);
    thread_ = std::thread([this, script = std::move(script)] {
      while (!stop_) {
        pollfd p{acceptor_.native_handle(), POLLIN, 0};
        if (::poll(&p, 1, 20) <= 0) continue;
        asio::error_code ec;
        tcp::socket socket(io_);
        acceptor_.accept(socket, ec);
        if (ec) continue;
        ++accepted_;
        Session session(std::move(socket));
        if (!session.hello()) continue;
        script(session, stop_);
        while (!stop_ && session.receive(0.02, [](const v1::ClientMessage&) {})) {
        }
      }
    });
  }
  ~FakeServer() {
    stop_ = true;
    thread_.join();
  }
  std::uint16_t port() const { return acceptor_.local_endpoint().port(); }
  int accepted() const { return accepted_; }

 private:
  asio::io_context io_;
  tcp::acceptor acceptor_;
  std::atomic<bool> stop_{false};
  std::atomic<int> accepted_{0};
  std::thread thread_;
};

v1::ServerMessage welcome() {
  v1::ServerMessage m;
  m.mutable_welcome()->set_protocol_version(1);
  m.mutable_welcome()->set_server_name("fake");
  m.mutable_welcome()->set_tick_rate_hz(1000);
  return m;
}

// An 8 x 8 x 8 scene of 1 mm voxels.
v1::ServerMessage scene8() {
  v1::ServerMessage m;
  v1::Grid* g = m.mutable_scene()->mutable_grid();
  for (int a = 0; a < 3; ++a) {
    g->add_dims(8);
    g->add_spacing(1.0);
  }
  m.mutable_scene()->set_source("fake:8");
  return m;
}

// Chunk `index` of `count` of the 8^3 volume at step 1: slices k_begin .. k_begin + k_count.
v1::ServerMessage chunk(std::uint32_t index, std::uint32_t count, std::uint32_t k_begin,
                        std::uint32_t k_count, std::size_t surf_bytes = 0) {
  v1::ServerMessage m;
  v1::VolumeChunk* c = m.mutable_volume();
  c->set_step(1);
  for (int a = 0; a < 3; ++a) {
    c->add_dims(8);
    c->add_spacing(1.0);
  }
  c->set_k_begin(k_begin);
  c->set_k_count(k_count);
  c->set_chunk_index(index);
  c->set_chunk_count(count);
  std::vector<float> values(64 * k_count);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<float>(k_begin * 64 + i);
  std::string bytes(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
  if (surf_bytes) bytes.resize(surf_bytes);
  c->set_d_surf(bytes);
  return m;
}

TEST(StreamClient, AssemblesAVolumeFromChunksInOrder) {
  FakeServer server([](FakeServer::Session& s, const std::atomic<bool>&) {
    s.send(welcome());
    s.send(scene8());
    s.send(chunk(0, 3, 0, 3));
    s.send(chunk(1, 3, 3, 3));
    s.send(chunk(2, 3, 6, 2));
    v1::ServerMessage f;
    f.mutable_frame()->set_seq(7);
    s.send(f);
  });
  StreamOptions o = options_for(server.port());
  o.volume_max_dim = 8;
  o.stall_s = 30;  // one frame only: stay Live
  StreamClient client(o);
  client.start();
  const LatestState s =
      wait_for(client, [](const LatestState& l) { return is_state(l, LinkState::Live); });
  ASSERT_EQ(s.link.state, LinkState::Live) << s.link.message;
  ASSERT_TRUE(s.volume);
  ASSERT_EQ(s.volume->d_surf.size(), 512u);
  for (std::size_t i = 0; i < 512; ++i) ASSERT_EQ(s.volume->d_surf[i], static_cast<float>(i));
  EXPECT_TRUE(s.volume->d_bone.empty());
  EXPECT_EQ(s.frame.seq, 7u);
  EXPECT_EQ(s.frame.device_state, view::DeviceState::Unknown);  // unset in the frame
  EXPECT_TRUE(s.scene->device_renders_force == false);          // unset: proto3 default
}

// The CT (HU and body mask) and the maps as zlib streams, inflated to exactly their slices.
v1::ServerMessage ct_chunk(std::uint32_t index, std::uint32_t count, std::uint32_t k_begin,
                           std::uint32_t k_count) {
  v1::ServerMessage m = chunk(index, count, k_begin, k_count);
  v1::VolumeChunk* c = m.mutable_volume();
  std::vector<std::int16_t> hu(64 * k_count);
  std::string body(hu.size(), '\0');
  for (std::size_t i = 0; i < hu.size(); ++i) {
    hu[i] = static_cast<std::int16_t>(-1000 + static_cast<int>(k_begin * 64 + i));
    body[i] = static_cast<char>(i % 2);
  }
  c->set_d_surf(wire::deflate_bytes(c->d_surf()));
  c->set_hu(wire::deflate_bytes(
      std::string(reinterpret_cast<const char*>(hu.data()), hu.size() * sizeof(std::int16_t))));
  c->set_body(wire::deflate_bytes(body));
  c->set_deflate(true);
  return m;
}

TEST(StreamClient, AssemblesADeflatedCtVolume) {
  FakeServer server([](FakeServer::Session& s, const std::atomic<bool>&) {
    s.send(welcome());
    s.send(scene8());
    s.send(ct_chunk(0, 2, 0, 5));
    s.send(ct_chunk(1, 2, 5, 3));
    v1::ServerMessage f;
    f.mutable_frame()->set_seq(3);
    s.send(f);
  });
  StreamOptions o = options_for(server.port());
  o.volume_max_dim = 8;
  o.stall_s = 30;
  StreamClient client(o);
  client.start();
  const LatestState s =
      wait_for(client, [](const LatestState& l) { return is_state(l, LinkState::Live); });
  ASSERT_EQ(s.link.state, LinkState::Live) << s.link.message;
  ASSERT_TRUE(s.volume);
  ASSERT_EQ(s.volume->hu.size(), 512u);
  ASSERT_EQ(s.volume->body.size(), 512u);
  for (std::size_t i = 0; i < 512; ++i) {
    ASSERT_EQ(s.volume->d_surf[i], static_cast<float>(i));
    ASSERT_EQ(s.volume->hu[i], -1000 + static_cast<int>(i));
    ASSERT_EQ(s.volume->body[i], (i % 64) % 2);
  }
}

// Each malformed stream drops the connection with a message naming the problem; the client
// neither crashes nor writes outside the volume, and retries (Reconnecting).
TEST(StreamClient, MalformedServerInputDropsTheConnectionWithAClearMessage) {
  struct Case {
    std::string name;
    std::vector<std::string> stream;  // encoded frames after the Welcome
    std::string expect;
  };
  const auto enc = [](const v1::ServerMessage& m) { return wire::encode_frame(m); };
  v1::ServerMessage huge = chunk(0, 1, 0, 1);
  huge.mutable_volume()->set_dims(0, 1 << 20);
  v1::ServerMessage dims_mismatch = chunk(0, 1, 0, 8);
  dims_mismatch.mutable_volume()->set_dims(0, 9);
  v1::ServerMessage bone_short = chunk(0, 1, 0, 8);
  bone_short.mutable_volume()->set_d_bone(std::string(12, '\0'));
  v1::ServerMessage bad_grid = scene8();
  bad_grid.mutable_scene()->mutable_grid()->set_spacing(1, -1.0);
  // Spacings no palpd serves (prep keeps them within [0.001, 100] mm, docs/security.md): a
  // palpview that took them hung past its --timeout (issue 37).
  v1::ServerMessage absurd_spacing = scene8();
  for (int a = 0; a < 3; ++a)
    absurd_spacing.mutable_scene()->mutable_grid()->set_spacing(a, a == 1 ? 1e-300 : 1e300);
  v1::ServerMessage frame;
  frame.mutable_frame()->set_seq(1);
  // A scene of 300^3 at step 1 and a first chunk that matches it: far more than the client's 8
  // a side. Refused before the 200 MB it claims is allocated.
  v1::ServerMessage big_scene = scene8();
  v1::ServerMessage big_chunk = chunk(0, 300, 0, 1);
  for (int a = 0; a < 3; ++a) {
    big_scene.mutable_scene()->mutable_grid()->set_dims(a, 300);
    big_chunk.mutable_volume()->set_dims(a, 300);
  }
  // A zlib stream that inflates to far more than its slices (a "bomb": 64 MiB of zeros), one
  // that is not zlib, and HU without the body mask.
  v1::ServerMessage bomb = ct_chunk(0, 1, 0, 8);
  bomb.mutable_volume()->set_hu(wire::deflate_bytes(std::string(64u << 20, '\0')));
  v1::ServerMessage not_zlib = ct_chunk(0, 1, 0, 8);
  not_zlib.mutable_volume()->set_body("not zlib");
  v1::ServerMessage hu_alone = chunk(0, 1, 0, 8);
  hu_alone.mutable_volume()->set_hu(std::string(1024, '\0'));
  const std::vector<Case> cases = {
      {"deflate bomb", {enc(scene8()), enc(bomb)}, "hu: not a zlib stream of 1024 bytes"},
      {"not zlib", {enc(scene8()), enc(not_zlib)}, "body: not a zlib stream of 512 bytes"},
      {"hu without body", {enc(scene8()), enc(hu_alone)}, "hu and body come together"},
      {"more than asked", {enc(big_scene), enc(big_chunk)}, "asked for at most 8 a side"},
      {"short d_surf", {enc(scene8()), enc(chunk(0, 2, 0, 4, 10))}, "d_surf has 10 bytes"},
      {"long d_surf", {enc(scene8()), enc(chunk(0, 2, 0, 4, 1025))}, "d_surf has 1025 bytes"},
      {"gap", {enc(scene8()), enc(chunk(0, 2, 0, 4)), enc(chunk(1, 2, 5, 3))}, "k_begin 5"},
      {"past the end", {enc(scene8()), enc(chunk(0, 2, 0, 4)), enc(chunk(1, 2, 4, 5))}, "outside"},
      {"missing chunk 0", {enc(scene8()), enc(chunk(1, 2, 4, 4))}, "without chunk 0"},
      {"index past count", {enc(scene8()), enc(chunk(2, 2, 0, 4))}, "index 2 of 2"},
      {"too few slices", {enc(scene8()), enc(chunk(0, 1, 0, 4))}, "cover 4 of 8 slices"},
      {"huge", {enc(scene8()), enc(huge)}, "out of 1..65536"},
      {"not the scene's grid", {enc(scene8()), enc(dims_mismatch)}, "the scene's grid"},
      {"d_bone size", {enc(scene8()), enc(bone_short)}, "d_bone has 12 bytes"},
      {"bad grid", {enc(bad_grid)}, "grid spacing (1, -1, 1) mm is outside"},
      {"absurd spacing", {enc(absurd_spacing)}, "grid spacing (1e+300, 1e-300, 1e+300) mm"},
      {"frame mid-volume",
       {enc(scene8()), enc(chunk(0, 2, 0, 4)), enc(frame)},
       "before the render"},
      {"bad prefix", {enc(scene8()), std::string(10, '\xff')}, "bad frame from the server"},
      {"undecodable", {std::string("\x03\xff\xff\xff", 4)}, "undecodable"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    FakeServer server([&](FakeServer::Session& s, const std::atomic<bool>&) {
      std::string bytes = wire::encode_frame(welcome());
      for (const std::string& f : c.stream) bytes += f;
      s.send_raw(bytes);
    });
    StreamOptions o = options_for(server.port());
    o.volume_max_dim = 8;
    o.reconnect_min_s = o.reconnect_max_s = 30;  // one attempt within the test
    StreamClient client(o);
    client.start();
    const LatestState s =
        wait_for(client, [](const LatestState& l) { return is_state(l, LinkState::Reconnecting); });
    EXPECT_EQ(s.link.state, LinkState::Reconnecting);
    EXPECT_NE(s.link.message.find(c.expect), std::string::npos) << s.link.message;
    EXPECT_FALSE(s.volume);
    EXPECT_EQ(s.link.connections, 1u);
  }
}

TEST(StreamClient, SomethingBeforeWelcomeAndFatalErrorsAreReported) {
  {
    FakeServer server([](FakeServer::Session& s, const std::atomic<bool>&) { s.send(scene8()); });
    StreamClient client(options_for(server.port()));
    client.start();
    const LatestState s =
        wait_for(client, [](const LatestState& l) { return is_state(l, LinkState::Reconnecting); });
    EXPECT_NE(s.link.message.find("before its Welcome"), std::string::npos) << s.link.message;
    EXPECT_EQ(s.link.connections, 0u);
  }
  {
    // A full server is worth retrying: the client comes back with backoff.
    FakeServer server([](FakeServer::Session& s, const std::atomic<bool>&) {
      v1::ServerMessage m;
      m.mutable_error()->set_code(v1::Error::TOO_MANY_CLIENTS);
      m.mutable_error()->set_reason("the server is full (16 clients)");
      m.mutable_error()->set_fatal(true);
      s.send(m);
    });
    StreamClient client(options_for(server.port()));
    client.start();
    const LatestState s = wait_for(client, [&](const LatestState& l) {
      return is_state(l, LinkState::Reconnecting) && server.accepted() >= 3;
    });
    EXPECT_EQ(s.link.state, LinkState::Reconnecting);
    EXPECT_NE(s.link.message.find("TOO_MANY_CLIENTS: the server is full"), std::string::npos)
        << s.link.message;
    EXPECT_GE(server.accepted(), 3);
  }
}

// A server whose clock is 1000 s ahead of this one stamps each frame 3 ms before it sends it:
// with the Ping/Pong offset the latency is 3 ms plus the transit, not -1e6 ms. Stats give the
// delivered fraction over each interval and the device state (unset until the server says).
TEST(StreamClient, ClockOffsetLatencyAndStatsFromAFakeServer) {
  constexpr std::int64_t kAhead = 1'000'000'000'000;  // 1000 s
  const auto server_now = [] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
               .count() +
           kAhead;
  };
  std::atomic<int> phase{0};
  FakeServer server([&](FakeServer::Session& s, const std::atomic<bool>& stop) {
    s.send(welcome());
    s.send(scene8());
    std::uint64_t seq = 0;
    int sent_phase = 0;
    while (!stop && !s.closed()) {
      s.receive(0.005, [&](const v1::ClientMessage& m) {
        if (!m.has_ping()) return;
        v1::ServerMessage pong;
        pong.mutable_pong()->set_id(m.ping().id());
        pong.mutable_pong()->set_client_time_ns(m.ping().client_time_ns());
        pong.mutable_pong()->set_server_time_ns(server_now());
        s.send(pong);
      });
      v1::ServerMessage f;
      f.mutable_frame()->set_seq(++seq);
      f.mutable_frame()->set_server_time_ns(server_now() - 3'000'000);
      f.mutable_frame()->mutable_force()->set_z(1.5);
      s.send(f);
      if (phase > sent_phase) {
        sent_phase = phase;
        v1::ServerMessage st;
        st.mutable_stats()->set_rate_hz(999.5);
        if (sent_phase == 1) {
          st.mutable_stats()->set_client_frames_sent(90);
          st.mutable_stats()->set_client_frames_dropped(10);
        } else {
          st.mutable_stats()->set_client_frames_sent(180);
          st.mutable_stats()->set_client_frames_dropped(10);
          st.mutable_stats()->set_device_state(v1::DEVICE_ABSENT);
          st.mutable_stats()->set_device_message("unplugged");
        }
        s.send(st);
      }
    }
  });
  StreamOptions o = options_for(server.port());
  o.volume_max_dim = 0;
  o.stall_s = 5;  // a loaded machine may pause the fake server's loop
  StreamClient client(o);
  client.start();
  LatestState s = wait_for(client, [](const LatestState& l) {
    return is_state(l, LinkState::Live) && l.link.latency_ms != -1;
  });
  ASSERT_EQ(s.link.state, LinkState::Live) << s.link.message;
  const double half_rtt = s.link.rtt_ms / 2 + 1e-6;
  EXPECT_NEAR(s.link.clock_offset_ms, 1e6, half_rtt);
  EXPECT_GE(s.link.latency_ms, 3.0 - half_rtt);
  EXPECT_LT(s.link.latency_ms, 3.0 + 1000.0);  // loopback transit, however loaded
  EXPECT_EQ(s.link.delivered, -1.0);           // no Stats yet
  EXPECT_EQ(s.link.device_state, view::DeviceState::Unknown);
  EXPECT_EQ(s.frame.force.z, 1.5);

  phase = 1;
  s = wait_for(client, [](const LatestState& l) { return l.link.delivered >= 0; });
  EXPECT_EQ(s.link.delivered, 0.9);  // 90 of 100
  EXPECT_EQ(s.link.server_tick_rate_hz, 999.5);
  EXPECT_EQ(s.link.device_state, view::DeviceState::Unknown);
  phase = 2;
  s = wait_for(client, [](const LatestState& l) { return l.link.delivered == 1.0; });
  EXPECT_EQ(s.link.delivered, 1.0);  // 90 more sent, none dropped in the interval
  EXPECT_EQ(s.link.device_state, view::DeviceState::Absent);
  EXPECT_EQ(s.link.device_message, "unplugged");
}

}  // namespace
}  // namespace palp
