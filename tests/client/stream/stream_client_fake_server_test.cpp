// palpview's network layer (client/stream/stream_client) against scripted fake palp.v1 servers
// on loopback: a volume assembled from its chunks (plain and deflated), malformed volume chunks
// and frames drop the connection with a clear message, something before Welcome and fatal errors
// are reported, the Ping/Pong clock offset makes latency right for a server whose clock is
// 1000 s ahead, and the delivered fraction and device state come from Stats.
#include "stream/stream_client.hpp"

#include <poll.h>

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "asio.hpp"
#include "support/stream_client_waits.hpp"
#include "wire/framing.hpp"
#include "wire/messages.hpp"
#include "wire/volume_codec.hpp"

namespace palp {
namespace {

namespace v1 = palp::v1;
using asio::ip::tcp;
using testing::is_state;
using testing::options_for;
using testing::wait_for;
using view::LatestState;
using view::LinkState;
using view::StreamClient;
using view::StreamOptions;

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
