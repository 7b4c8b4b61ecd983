// palpview's network layer (client/stream/stream_client) against the real palpd, started with
// posix_spawn so the test can SIGSTOP, SIGCONT and SIGKILL it (scenes prepped into a private
// PALP_SCENE_CACHE): scene and render volume (compared voxel for voxel with the prepped map),
// frames, Stalled and Live again, a late joiner's force history, reconnection to a restarted
// server, refusal on a wrong token, the controller driving the `remote` device, command results.
// Every wait is for a condition with a generous timeout; nothing gates on speed.
#include "stream/stream_client.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "io/phantom.hpp"
#include "support/cli_test_util.hpp"
#include "support/stream_client_waits.hpp"
#include "wire/messages.hpp"
#include "wire/volume_codec.hpp"

extern char** environ;

namespace palp {
namespace {

namespace fs = std::filesystem;
using testing::is_state;
using testing::options_for;
using testing::read_text;
using testing::shared_cli_dir;
using testing::wait_for;
using view::LatestState;
using view::LinkState;
using view::StreamClient;
using view::StreamOptions;

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

}  // namespace
}  // namespace palp
