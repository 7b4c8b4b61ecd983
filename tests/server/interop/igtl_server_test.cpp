// The OpenIGTLink server in-process (server/interop/igtl_server.cpp): the rate it keeps, what a
// message holds, the client bound, and a client that never reads dropped while another is served.
#include "interop/igtl_server.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "interop/igtl_frame.hpp"

namespace palp::interop {
namespace {

Grid lps_grid() {
  Grid g;
  g.dims = {10, 10, 10};
  g.world.origin = {10, 20, 30};
  return g;
}

rt::Snapshot snapshot_at(std::int64_t t_ns, double x) {
  rt::Snapshot s;
  s.tick.t_ns = t_ns;
  s.tick.pose.position = {x, 2, 3};
  s.tick.force = {1, 0, -2};
  s.tick.u = {0, 0.5, 0};
  return s;
}

int connect_to(std::uint16_t port, int rcvbuf = 0) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (rcvbuf > 0) ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// Reads what arrives within `ms`; false when the peer closed.
bool read_for(int fd, int ms, std::string& out) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
  while (std::chrono::steady_clock::now() < end) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 10) <= 0) continue;
    char buf[65536];
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) return false;
    out.append(buf, static_cast<std::size_t>(n));
  }
  return true;
}

struct Message {
  std::string type, name;
  float body[12];
};

// Splits a byte stream into OpenIGTLink messages (58-byte header, big-endian).
std::vector<Message> parse(const std::string& bytes) {
  std::vector<Message> out;
  std::size_t at = 0;
  while (at + 58 <= bytes.size()) {
    const auto* p = reinterpret_cast<const unsigned char*>(bytes.data() + at);
    std::uint64_t size = 0;
    for (int i = 0; i < 8; ++i) size = size << 8 | p[42 + i];
    if (at + 58 + size > bytes.size()) break;
    Message m;
    m.type = std::string(reinterpret_cast<const char*>(p + 2),
                         strnlen(reinterpret_cast<const char*>(p + 2), 12));
    m.name = std::string(reinterpret_cast<const char*>(p + 14),
                         strnlen(reinterpret_cast<const char*>(p + 14), 20));
    for (int i = 0; i < 12 && size == 48; ++i) {
      std::uint32_t v = 0;
      for (int b = 0; b < 4; ++b) v = v << 8 | p[58 + 4 * i + b];
      std::memcpy(&m.body[i], &v, 4);
    }
    out.push_back(m);
    at += 58 + size;
  }
  return out;
}

TEST(IgtlServer, KeepsOneSamplePerIntervalOfLoopTime) {
  IgtlConfig config;
  config.port = 0;
  config.rate_hz = 60;
  IgtlServer server(config, lps_grid());
  // 1 kHz for one second of loop time: samples at 0, 1/60 s, ... -> 60 of them.
  for (int i = 0; i < 1000; ++i) server.offer(snapshot_at(i * 1'000'000LL + 5, i));
  EXPECT_EQ(server.counters().samples_offered, 60u);
}

TEST(IgtlServer, SendsThePoseForceAndUInRas) {
  IgtlConfig config;
  config.port = 0;
  IgtlServer server(config, lps_grid());
  server.start();
  const int fd = connect_to(server.port());
  ASSERT_GE(fd, 0);
  for (int i = 0; i < 100 && server.client_count() == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  server.offer(snapshot_at(1'000'000'000, 1.0));
  std::string bytes;
  read_for(fd, 300, bytes);
  const std::vector<Message> m = parse(bytes);
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0].type, "TRANSFORM");
  EXPECT_EQ(m[0].name, "PalpTool");
  EXPECT_EQ(m[1].name, "PalpForce");
  EXPECT_EQ(m[2].name, "PalpU");
  // Columns R11 R21 R31 R12 R22 R32 R13 R23 R33 TX TY TZ: identity orientation in LPS storage
  // -> diag(-1, -1, 1); scene (1, 2, 3) + origin (10, 20, 30) LPS -> RAS (-11, -22, 33).
  const float tool[12] = {-1, 0, 0, 0, -1, 0, 0, 0, 1, -11, -22, 33};
  for (int i = 0; i < 12; ++i) EXPECT_EQ(m[0].body[i], tool[i]) << i;
  EXPECT_EQ(m[1].body[9], -1.0f);  // force (1, 0, -2) scene -> RAS (-1, 0, -2)
  EXPECT_EQ(m[1].body[10], 0.0f);
  EXPECT_EQ(m[1].body[11], -2.0f);
  EXPECT_EQ(m[2].body[10], -0.5f);  // u (0, 0.5, 0) -> RAS (0, -0.5, 0)
  ::close(fd);
}

TEST(IgtlServer, RefusesClientsBeyondTheBound) {
  IgtlConfig config;
  config.port = 0;
  config.max_clients = 2;
  IgtlServer server(config, lps_grid());
  server.start();
  const int a = connect_to(server.port()), b = connect_to(server.port());
  for (int i = 0; i < 100 && server.client_count() < 2; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const int c = connect_to(server.port());
  std::string ignored;
  EXPECT_FALSE(read_for(c, 1000, ignored));  // closed at once
  EXPECT_EQ(server.client_count(), 2u);
  EXPECT_EQ(server.counters().refused, 1u);
  for (int fd : {a, b, c}) ::close(fd);
}

TEST(IgtlServer, AClientThatNeverReadsIsDroppedAndTheOthersServed) {
  IgtlConfig config;
  config.port = 0;
  config.rate_hz = 1000;
  config.queue_samples = 4;
  config.write_timeout_s = 0.3;
  config.send_buffer_bytes = 4096;  // the kernel holds little: the stall shows within ms
  IgtlServer server(config, lps_grid());
  server.start();
  const int stuck = connect_to(server.port(), 2048);
  const int good = connect_to(server.port());
  for (int i = 0; i < 100 && server.client_count() < 2; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_EQ(server.client_count(), 2u);
  // Loop time runs 1 ms per offer; the good client reads throughout.
  std::string got;
  std::int64_t t = 1'000'000;
  for (int round = 0; round < 400 && server.counters().timeouts == 0; ++round) {
    for (int i = 0; i < 20; ++i) {
      server.offer(snapshot_at(t, 1.0));
      t += 1'000'000;
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    read_for(good, 1, got);
  }
  const IgtlCounters c = server.counters();
  EXPECT_EQ(c.timeouts, 1u);
  EXPECT_GT(c.samples_dropped, 0u);
  EXPECT_EQ(server.client_count(), 1u);
  // The good client still gets samples after the stuck one is gone.
  const std::size_t before = parse(got).size();
  for (int i = 0; i < 50; ++i) {
    server.offer(snapshot_at(t, 1.0));
    t += 1'000'000;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  read_for(good, 200, got);
  EXPECT_GT(parse(got).size(), before);
  ::close(stuck);
  ::close(good);
}

}  // namespace
}  // namespace palp::interop
