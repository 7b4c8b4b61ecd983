// StreamClient::Impl (internal, Asio): the network thread's state and the steps it runs.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "asio.hpp"
#include "client_core/message_reader.hpp"
#include "palp.pb.h"
#include "stream/clock_sync.hpp"
#include "stream/stream_client.hpp"
#include "stream/volume_assembly.hpp"
#include "tls/tls_context.hpp"

namespace palp::view {

// Its steps are defined in stream_client.cpp (lifecycle, connect, read, write, reconnect,
// housekeeping) and server_messages.cpp (the on_* message handlers).
struct StreamClient::Impl {
  using tcp = asio::ip::tcp;

  // One TCP connection attempt and its session.
  struct Connection {
    explicit Connection(asio::io_context& io) : stream(io), resolver(io), reader("the server") {}
    palp::tls::Stream stream;  // plain, or TLS once connected (opts.tls_*)
    tcp::resolver resolver;
    client::ServerMessageReader reader;  // the frames decoded into ServerMessages
    std::array<std::uint8_t, 65536> read_buffer{};
    std::string out_pending, out_inflight;  // bytes to write / being written
    bool writing = false;
    bool connected = false;  // TCP up, Hello sent
    bool welcomed = false;
    std::int64_t started_ns = 0, last_rx_ns = 0;
    std::int64_t first_frame_ns = 0;         // arrival of the first frame (0: none yet)
    std::int64_t first_frame_server_ns = 0;  // its server_time_ns: force history t = 0
    std::int64_t last_history_server_ns = 0;
    std::vector<ForceSample> joined_history;  // palpd's ForceHistory, until the first frame
    std::uint64_t frames = 0;
    int pings = 0;
    std::int64_t last_ping_ns = 0;
    net::ClockSync clock;    // Ping/Pong clock offset
    net::Arrivals arrivals;  // frames of the last second
    bool have_stats = false;
    std::uint64_t stats_sent = 0, stats_dropped = 0;
    std::optional<net::SceneGrid> scene_grid;  // from SceneInfo
    net::VolumeAssembly assembly;              // the render volume being assembled
  };
  using ConnectionPtr = std::shared_ptr<Connection>;

  // What the render thread queues for the network thread.
  struct Outbox {
    std::optional<Pose> pose;
    std::deque<std::pair<std::uint64_t, std::string>> commands;  // request id, encoded frame
    bool wake_posted = false;
  };

  explicit Impl(const StreamOptions& o)
      : opts(o), tls(make_tls(o)), retry_timer(io), house_timer(io), tick_ns(house_period_ns(o)) {}

  // The housekeeping timer's period: stall_s / 4, within 5..50 ms.
  static std::int64_t house_period_ns(const StreamOptions& o);

  // ------------------------------------------------------------------ lifecycle
  void start();
  void stop();

  // ------------------------------------------------------------------ connecting
  void start_connect();
  std::string endpoint_text() const;
  void send_hello(Connection& c);
  static void close(Connection& c);

  // The connection failed: Reconnecting, retry after the backoff delay.
  void drop(const ConnectionPtr& c, const std::string& why);

  // The server refused this client for good: Refused, no retry.
  void refuse(const ConnectionPtr& c, const std::string& why);
  void reset_rates_locked();

  // ------------------------------------------------------------------ reading
  void read(const ConnectionPtr& c);

  // ------------------------------------------------------------------ messages
  // server_messages.cpp: each message checked, decoded (frame_decoding, volume_assembly,
  // handshake, clock_sync) and applied to the connection and to `shared`. ProtocolViolation drops
  // the connection.
  void on_message(const ConnectionPtr& c, const v1::ServerMessage& m, std::int64_t now);
  void on_welcome(const ConnectionPtr& c, const v1::Welcome& w, std::int64_t now);
  void on_scene(Connection& c, const v1::SceneInfo& s);
  void on_volume(Connection& c, const v1::VolumeChunk& chunk);
  void on_frame(Connection& c, const v1::HapticFrame& f, std::int64_t now);
  void on_stats(Connection& c, const v1::Stats& s);
  void on_history(Connection& c, const v1::ForceHistory& h);
  void on_task(const v1::TaskStatus& t);
  void on_landmarks(const v1::LandmarkSet& set);
  void on_error(const ConnectionPtr& c, const v1::Error& e);
  void on_pong(Connection& c, const v1::Pong& p, std::int64_t now);

  // ------------------------------------------------------------------ writing
  void ping(Connection& c, std::int64_t now);

  // Moves what the render thread queued into the connection and starts a write when none is in
  // flight. The newest pose is taken at the moment the socket can take it.
  void flush(const ConnectionPtr& c);

  // Render thread -> network thread.
  void wake();

  void queue_pose(const Pose& pose);
  std::uint64_t queue_command(v1::ClientMessage& m, const std::string& invalid);
  void record_result(std::uint64_t id, bool ok, const std::string& message);
  void fail_queued_commands(const std::string& why);

  // dds_source.cpp: with opts.dds, the thread's body instead of the Asio loop (until dds_stop).
  void run_dds();
  std::atomic<bool> dds_stop{false};
  // run_dds(): no subscriber for the rig; the link says why.
  void dds_refused(const std::string& why);
  // run_dds(): the one Connection a DDS link has, welcomed, the link loading.
  ConnectionPtr start_dds_link(const std::string& where);
  // run_dds()'s housekeeping() after each take: rates, latency, stalls.
  void dds_housekeeping(Connection& c, const std::string& where);

  // ------------------------------------------------------------------ housekeeping
  void schedule_house();
  void housekeeping(std::int64_t now);

  // ------------------------------------------------------------------ members
  const StreamOptions opts;
  // The TLS context (null: plain text), built once; UsageError / ResourceError from the ctor.
  static std::unique_ptr<palp::tls::ClientContext> make_tls(const StreamOptions& o) {
    if (o.tls_ca.empty() && o.tls_pin.empty()) return nullptr;
    return std::make_unique<palp::tls::ClientContext>(
        palp::tls::ClientOptions{o.tls_ca, o.tls_pin, o.tls_cert, o.tls_key});
  }
  const std::unique_ptr<palp::tls::ClientContext> tls;
  asio::io_context io;
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work;
  asio::steady_timer retry_timer, house_timer;
  const std::int64_t tick_ns;
  std::thread thread;

  // Network thread only.
  ConnectionPtr conn;
  int attempt = 0;  // failed attempts since the last Welcome
  bool refused = false;
  bool stopping = false;
  std::uint64_t ping_id = 0;
  std::string server_name;
  std::vector<double> latencies;  // scratch

  // Shared with the render thread.
  mutable std::mutex shared_mutex;
  LatestState shared;               // force_history stays empty: `history` holds it
  std::deque<ForceSample> history;  // under shared_mutex
  std::int64_t last_frame_ns = 0;   // under shared_mutex
  std::mutex outbox_mutex;
  Outbox outbox;
  std::atomic<std::uint64_t> next_request_id{0};
  std::atomic<bool> accept_poses{false}, accept_commands{false};
};

}  // namespace palp::view
