// Adversarial suite, palpd: the built palpd (remote device, Falcon limits, a token) faces a
// battery of hostile clients at once - garbage, oversize length prefixes, slowloris Hellos, a
// pre-Hello flood, a Ping flood and a Command flood from clients that never read, token
// guessing, out-of-range parameters, path-like recording names, NaN and huge poses - while an
// honest observer asks for every tick. Asserted: palpd's peak memory stays under kPalpdBound, the
// observer receives at least 99 % of the ticks between its first and last frame, every streamed
// force is finite and within the Falcon's 8 N, nothing is written outside the record directory,
// and palpd still exits cleanly. The write timeout is off, so only the per-client queue bound
// stops the clients that flood and never read.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <regex>
#include <thread>

#include "adversarial/adversarial_util.hpp"
#include "support/net_test_client.hpp"
#include "wire/framing.hpp"

namespace palp::adversarial {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using testing::TestClient;

constexpr std::size_t kPalpdBound = std::size_t{256} << 20;
constexpr double kFalconMaxForceN = 8.0;
constexpr double kBatterySeconds = 6.0;
const char* const kToken = "adversarial-token";

// A raw TCP connection to 127.0.0.1:port with receive timeouts; -1 when refused.
int raw_connect(int port, int receive_buffer = 0) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  if (receive_buffer > 0)
    ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &receive_buffer, sizeof receive_buffer);
  timeval tv{0, 200000};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// Reads until the peer closes or `seconds` pass; true when it closed.
bool drained_until_closed(int fd, double seconds) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
  char buffer[4096];
  while (Clock::now() < deadline) {
    const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
    if (n == 0) return true;
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) return true;
  }
  return false;
}

std::string hello_frame(v1::Role role, const std::string& token, double rate = 0.0) {
  v1::ClientMessage m;
  v1::Hello* h = m.mutable_hello();
  h->set_protocol_version(wire::kProtocolVersion);
  h->set_role(role);
  h->set_token(token);
  h->set_client_name("adversary");
  h->set_frame_rate_hz(rate);
  return wire::encode_frame(m);
}

v1::ClientMessage parameter(const std::string& name, double value, std::uint64_t id) {
  v1::ClientMessage m;
  m.mutable_command()->set_request_id(id);
  m.mutable_command()->mutable_set_parameter()->set_name(name);
  m.mutable_command()->mutable_set_parameter()->set_value(value);
  return m;
}

v1::ClientMessage recording(const std::string& name, std::uint64_t id) {
  v1::ClientMessage m;
  m.mutable_command()->set_request_id(id);
  m.mutable_command()->mutable_start_recording()->set_name(name);
  return m;
}

v1::ClientMessage pose(double x, double y, double z) {
  v1::ClientMessage m;
  v1::Pose* p = m.mutable_device_pose()->mutable_pose();
  p->mutable_position()->set_x(x);
  p->mutable_position()->set_y(y);
  p->mutable_position()->set_z(z);
  p->mutable_orientation()->set_w(1.0);
  return m;
}

struct ObserverReport {
  std::uint64_t frames = 0, first = 0, last = 0, bad_forces = 0;
  double max_force = 0.0;
};

class HostileClients : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(dir_.path() / "records");
    const std::vector<std::string> args = {PALPD_PATH,        "--scene",
                                           "phantom:sphere",  "--device",
                                           "remote",          "--device-profile",
                                           "falcon",          "--no-realtime",
                                           "--port",          "0",
                                           "--token",         kToken,
                                           "--write-timeout", "0",
                                           "--duration",      "60",
                                           "--record-dir",    (dir_.path() / "records").string()};
    palpd_ = std::make_unique<Child>(args, dir_.file("palpd.out"), dir_.file("palpd.out"),
                                     std::vector<std::string>{cache_env_});
    const std::regex listening("listening on 127\\.0\\.0\\.1:([0-9]+)");
    for (int i = 0; i < 600 && port_ == 0; ++i) {
      std::smatch match;
      const std::string text = read_text(dir_.file("palpd.out"));
      if (std::regex_search(text, match, listening)) port_ = std::stoi(match[1]);
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ASSERT_GT(port_, 0) << read_text(dir_.file("palpd.out"));
  }

  ScratchDir dir_{"palpd"};
  std::string cache_env_ = "PALP_SCENE_CACHE=" + dir_.file("cache");
  std::unique_ptr<Child> palpd_;
  int port_ = 0;
};

TEST_F(HostileClients, PalpdStaysBoundedAndAnObserverKeepsItsTicks) {
  std::atomic<bool> stop{false};
  // Every thread of the test; stopped and joined however the test ends.
  std::vector<std::thread> threads;
  std::atomic<int> ping_bursts{0};
  TestClient pinger(static_cast<std::uint16_t>(port_), 4096);
  struct Joiner {
    std::atomic<bool>& stop;
    std::vector<std::thread>& threads;
    void join() {
      stop.store(true);
      for (auto& t : threads)
        if (t.joinable()) t.join();
    }
    ~Joiner() { join(); }
  } joiner{stop, threads};

  // The honest observer: every tick, forces checked.
  ObserverReport report;
  TestClient observer(static_cast<std::uint16_t>(port_));
  observer.hello(v1::OBSERVER, "", wire::kProtocolVersion, 0, 0.0);
  v1::ServerMessage m;
  ASSERT_TRUE(observer.wait_for_case(v1::ServerMessage::kFrame, m));
  threads.emplace_back([&] {
    v1::ServerMessage f;
    while (!stop.load()) {
      if (!observer.next(f, 1.0)) continue;
      if (f.msg_case() != v1::ServerMessage::kFrame) continue;
      const auto& force = f.frame().force();
      const double n =
          std::sqrt(force.x() * force.x() + force.y() * force.y() + force.z() * force.z());
      if (!std::isfinite(n) || n > kFalconMaxForceN + 1e-9) ++report.bad_forces;
      if (std::isfinite(n)) report.max_force = std::max(report.max_force, n);
      if (report.frames == 0) report.first = f.frame().seq();
      report.last = f.frame().seq();
      ++report.frames;
    }
  });

  // The controller: out-of-range parameters and path-like names are refused, poses that are
  // NaN or huge drive nothing out of bounds; then it floods commands and never reads.
  TestClient controller(static_cast<std::uint16_t>(port_), 4096);
  controller.hello(v1::CONTROLLER, kToken);
  ASSERT_TRUE(controller.wait_for_case(v1::ServerMessage::kWelcome, m));
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Each is refused: a CommandResult with ok false, or (a non-finite value, an oversize name) a
  // non-fatal Error.
  std::uint64_t id = 1;
  const auto expect_refused = [&](const v1::ClientMessage& command, const std::string& what) {
    controller.send(command);
    const bool answered = controller.wait_for(
        [](const v1::ServerMessage& x) {
          return x.msg_case() == v1::ServerMessage::kResult ||
                 x.msg_case() == v1::ServerMessage::kError;
        },
        m, 5.0);
    ASSERT_TRUE(answered) << what;
    if (m.has_result()) {
      EXPECT_EQ(m.result().request_id(), command.command().request_id()) << what;
      EXPECT_FALSE(m.result().ok()) << what;
    } else {
      EXPECT_FALSE(m.error().fatal()) << what << ": " << m.error().reason();
    }
  };
  for (const auto& [name, value] : std::vector<std::pair<std::string, double>>{
           {"k", 1e308}, {"k", nan}, {"k", -inf}, {"c", -1.0}, {"bone_fmax", 1e6}, {"no", 1}})
    expect_refused(parameter(name, value, id++), name + " = " + std::to_string(value));
  for (const std::string& name :
       {std::string("../escaped"), std::string("/tmp/palp-abs"), std::string("a/b"),
        std::string("line\nbreak"), std::string("nul\0byte", 8), std::string(4096, 'x')})
    expect_refused(recording(name, id++), "recording " + name.substr(0, 20));
  pinger.hello(v1::OBSERVER, "", wire::kProtocolVersion, 0, 1.0);
  ASSERT_TRUE(pinger.wait_for_case(v1::ServerMessage::kWelcome, m));

  // Into the sphere (forces at the limit), then poses no device can reach.
  // The sphere phantom: radius 30 mm about (49.5, 49.5, 49.5) in the scene frame.
  for (int n = 0; n < 200; ++n) {
    controller.send(pose(49.5, 49.5, 95.0 - 0.15 * n));
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  for (double v : {nan, inf, -inf, 1e300, -1e300, 1e-300})
    for (int n = 0; n < 20; ++n) controller.send(pose(v, v, v));

  const auto until_stopped = [&](auto&& body) {
    threads.emplace_back([&, body] {
      while (!stop.load()) body();
    });
  };
  // The controller floods valid commands and never reads (its queue bound drops it).
  threads.emplace_back([&] {
    std::string burst;
    for (int n = 0; n < 1000; ++n) burst += wire::encode_frame(parameter("k", 0.5, 0));
    try {
      while (!stop.load()) controller.send_raw(burst);
    } catch (const std::exception&) {
    }
  });
  // Ping flood from an observer that never reads (welcomed before the pre-Hello flood starts).
  threads.emplace_back([&] {
    std::string burst;
    for (int n = 0; n < 1000; ++n) {
      v1::ClientMessage ping;
      ping.mutable_ping()->set_id(static_cast<std::uint64_t>(n));
      burst += wire::encode_frame(ping);
    }
    try {
      while (!stop.load()) {
        pinger.send_raw(burst);
        ++ping_bursts;
      }
    } catch (const std::exception&) {  // reset: palpd dropped it
    }
  });
  // Garbage.
  until_stopped([&] {
    const int fd = raw_connect(port_);
    if (fd < 0) return;
    std::string junk(4096, '\0');
    for (std::size_t i = 0; i < junk.size(); ++i) junk[i] = static_cast<char>(i * 131 + 7);
    send_all(fd, junk);
    drained_until_closed(fd, 1.0);
    ::close(fd);
  });
  // Oversize length prefixes (2^40 bytes announced).
  until_stopped([&] {
    const int fd = raw_connect(port_);
    if (fd < 0) return;
    send_all(fd, std::string("\x80\x80\x80\x80\x80\x20", 6));
    drained_until_closed(fd, 1.0);
    ::close(fd);
  });
  // Slowloris: a Hello one byte at a time.
  until_stopped([&] {
    const int fd = raw_connect(port_);
    if (fd < 0) return;
    const std::string hello = hello_frame(v1::OBSERVER, "");
    for (char c : hello) {
      if (stop.load() || !send_all(fd, std::string(1, c))) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(400));
    }
    ::close(fd);
  });
  // Pre-Hello flood: 100 silent sockets at a time.
  until_stopped([&] {
    std::vector<int> fds;
    for (int n = 0; n < 100; ++n)
      if (const int fd = raw_connect(port_); fd >= 0) fds.push_back(fd);
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    for (int fd : fds) ::close(fd);
  });
  // Token guessing.
  std::atomic<int> guesses{0};
  until_stopped([&] {
    const int fd = raw_connect(port_);
    if (fd < 0) return;
    send_all(fd, hello_frame(v1::CONTROLLER, "guess-" + std::to_string(guesses++)));
    drained_until_closed(fd, 1.0);
    ::close(fd);
  });

  // Watch palpd's memory while the battery runs.
  std::size_t peak = 0;
  const auto end = Clock::now() + std::chrono::duration<double>(kBatterySeconds);
  while (Clock::now() < end) {
    peak = std::max(peak, palpd_->vm_hwm_bytes());
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  joiner.join();
  peak = std::max(peak, palpd_->vm_hwm_bytes());

  palpd_->signal(SIGINT);
  ASSERT_TRUE(palpd_->wait(20.0));
  EXPECT_EQ(palpd_->exit_code(), 0) << read_text(dir_.file("palpd.out"));
  const std::string log = read_text(dir_.file("palpd.out"));

  const std::uint64_t ticks = report.last - report.first + 1;
  std::printf(
      "observer: %llu frames of %llu ticks (%.3f %%), max |F| %.3f N; palpd peak %.1f MiB; "
      "%d token guesses, %d ping bursts\n",
      static_cast<unsigned long long>(report.frames), static_cast<unsigned long long>(ticks),
      100.0 * static_cast<double>(report.frames) / static_cast<double>(ticks), report.max_force,
      static_cast<double>(peak) / 1048576.0, guesses.load(), ping_bursts.load());
  EXPECT_LT(peak, kPalpdBound);
  EXPECT_GT(report.frames, 1000u);
  EXPECT_GE(static_cast<double>(report.frames), 0.99 * static_cast<double>(ticks));
  EXPECT_EQ(report.bad_forces, 0u);
  EXPECT_GT(report.max_force, 0.0) << "the poses into the sphere produced no force";
  EXPECT_NE(log.find("wrong controller token"), std::string::npos) << log;
  // Nothing escaped the record directory.
  EXPECT_FALSE(fs::exists(dir_.path() / "escaped"));
  EXPECT_FALSE(fs::exists("/tmp/palp-abs"));
  EXPECT_TRUE(fs::is_empty(dir_.path() / "records"));
}

}  // namespace
}  // namespace palp::adversarial
