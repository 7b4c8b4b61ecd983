// palpview's network layer: see stream_client.hpp.
//
// Threads: the network thread runs an Asio io_context and owns everything in Impl except the two
// mutex-guarded parts: `shared` (the LatestState the render thread copies in latest()) and
// `outbox` (poses and commands the render thread queues). The render thread never blocks on the
// socket: it only takes those two short mutexes.
//
// One connection at a time, a fresh Connection object per attempt; every Asio callback holds the
// Connection it was started for and returns when that is no longer the current one, so a late
// callback of a dropped connection never touches the next.
//
//   start_connect -> resolve -> connect -> Hello -> read loop: frames decoded by
//   palp::wire::FrameDecoder -> on_message (Welcome, SceneInfo, VolumeChunk, HapticFrame, Stats,
//   CommandResult, Pong, Error) -> shared state
//   housekeeping timer (every <= 50 ms): Pings, rates, latency median, Stalled, silence timeout
//   drop(): close, Reconnecting, retry after reconnect_min_s * 2^attempt (capped)
#include "stream/stream_client.hpp"

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <new>
#include <optional>
#include <utility>

#include "asio.hpp"
#include "base/errors.hpp"
#include "wire/framing.hpp"
#include "wire/messages.hpp"

namespace palp::view {

namespace v1 = palp::v1;
using asio::ip::tcp;

const char* to_string(LinkState state) {
  switch (state) {
    case LinkState::Connecting:
      return "connecting";
    case LinkState::Loading:
      return "loading";
    case LinkState::Live:
      return "live";
    case LinkState::Stalled:
      return "stalled";
    case LinkState::Reconnecting:
      return "reconnecting";
    case LinkState::Refused:
      break;
  }
  return "refused";
}

const char* to_string(DeviceState state) {
  switch (state) {
    case DeviceState::Present:
      return "present";
    case DeviceState::Absent:
      return "absent";
    case DeviceState::Fault:
      return "fault";
    case DeviceState::Unknown:
      break;
  }
  return "unknown";
}

void parse_host_port(const std::string& text, std::string& host, std::uint16_t& port) {
  const auto bad = [&](const std::string& why) {
    return UsageError("expected HOST:PORT, got '" + text + "': " + why);
  };
  std::string host_part, port_part;
  if (!text.empty() && text.front() == '[') {
    const auto close = text.find(']');
    if (close == std::string::npos) throw bad("missing ']'");
    host_part = text.substr(1, close - 1);
    if (close + 1 >= text.size() || text[close + 1] != ':') throw bad("missing ':PORT'");
    port_part = text.substr(close + 2);
    if (host_part.find(':') == std::string::npos) throw bad("brackets are for IPv6 addresses");
  } else {
    const auto colon = text.rfind(':');
    if (colon == std::string::npos) throw bad("missing ':PORT'");
    host_part = text.substr(0, colon);
    port_part = text.substr(colon + 1);
    if (host_part.find(':') != std::string::npos)
      throw bad("write an IPv6 address in brackets: [ADDRESS]:PORT");
  }
  if (host_part.empty()) throw bad("empty host");
  for (const char c : host_part)
    if (static_cast<unsigned char>(c) <= ' ' || c == '[' || c == ']' || c == '/')
      throw bad("invalid character in the host");
  if (port_part.empty()) throw bad("empty port");
  if (port_part.size() > 5) throw bad("port out of range 1..65535");
  unsigned value = 0;
  for (const char c : port_part) {
    if (c < '0' || c > '9') throw bad("the port is not a number");
    value = value * 10 + static_cast<unsigned>(c - '0');
  }
  if (value < 1 || value > 65535) throw bad("port out of range 1..65535");
  host = host_part;
  port = static_cast<std::uint16_t>(value);
}

namespace {

// CLOCK_MONOTONIC on Linux (libstdc++'s steady_clock), the clock palpd stamps frames with: the
// clock offset estimate starts near 0 on the server's own host.
std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

constexpr std::int64_t kSecond = 1'000'000'000;
constexpr std::size_t kClockSamples = 32;       // min-RTT filter window (Pings)
constexpr int kFastPings = 5;                   // first Pings 100 ms apart, then 1 s
constexpr std::int64_t kMaxAxis = 1 << 16;      // render volume: voxels per axis
constexpr std::int64_t kMaxVoxels = 1LL << 28;  // render volume: voxels in all (1 GiB a map)
constexpr std::size_t kMaxNameBytes = palp::wire::kMaxNameBytes;

// A violation of palp.v1 by the server: the connection is dropped with this message.
class ProtocolViolation : public InputError {
 public:
  using InputError::InputError;
};

DeviceState device_state_of(v1::DeviceState s) {
  switch (s) {
    case v1::DEVICE_PRESENT:
      return DeviceState::Present;
    case v1::DEVICE_ABSENT:
      return DeviceState::Absent;
    case v1::DEVICE_FAULT:
      return DeviceState::Fault;
    default:
      return DeviceState::Unknown;
  }
}

// Fatal Errors that retrying cannot fix: the client asked for something the server will refuse
// again. Everything else (timeouts, a full server, shutting down) is retried.
bool is_refusal(v1::Error::Code code) {
  switch (code) {
    case v1::Error::VERSION_MISMATCH:
    case v1::Error::UNAUTHORIZED:
    case v1::Error::PERMISSION_DENIED:
    case v1::Error::CONTROLLER_BUSY:
    case v1::Error::EXPECTED_HELLO:
    case v1::Error::MALFORMED:
    case v1::Error::FRAME_TOO_LARGE:
    case v1::Error::BAD_REQUEST:
      return true;
    default:
      return false;
  }
}

std::string seconds_text(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2g s", s);
  return text;
}

bool positive_finite(double v) {
  return std::isfinite(v) && v > 0.0;
}

// Little-endian float32 bytes -> floats.
void copy_floats(const std::string& bytes, float* out) {
  std::memcpy(out, bytes.data(), bytes.size());
  if constexpr (std::endian::native == std::endian::big) {
    for (std::size_t i = 0; i < bytes.size() / sizeof(float); ++i) {
      std::uint32_t u;
      std::memcpy(&u, out + i, sizeof u);
      u = __builtin_bswap32(u);
      std::memcpy(out + i, &u, sizeof u);
    }
  }
}

void check_options(const StreamOptions& o) {
  if (o.host.empty()) throw UsageError("stream client: empty host");
  if (o.port == 0) throw UsageError("stream client: port 0");
  if (o.client_name.size() > kMaxNameBytes || o.token.size() > kMaxNameBytes)
    throw UsageError("stream client: client name or token longer than 256 bytes");
  if (!std::isfinite(o.frame_rate_hz) || o.frame_rate_hz < 0)
    throw UsageError("stream client: frame_rate_hz must be finite and >= 0");
  if (!positive_finite(o.stall_s)) throw UsageError("stream client: stall_s must be > 0");
  if (!positive_finite(o.reconnect_min_s) || !positive_finite(o.reconnect_max_s) ||
      o.reconnect_max_s < o.reconnect_min_s)
    throw UsageError("stream client: need 0 < reconnect_min_s <= reconnect_max_s");
  if (!std::isfinite(o.silence_timeout_s) || o.silence_timeout_s < 0)
    throw UsageError("stream client: silence_timeout_s must be >= 0");
  if (!std::isfinite(o.force_history_s) || o.force_history_s < 0)
    throw UsageError("stream client: force_history_s must be >= 0");
  if (o.max_queued_commands == 0) throw UsageError("stream client: max_queued_commands is 0");
}

}  // namespace

struct StreamClient::Impl {
  // One TCP connection attempt and its session.
  struct Connection {
    explicit Connection(asio::io_context& io)
        : socket(io), resolver(io), decoder(palp::wire::kDefaultMaxServerFrame) {}
    tcp::socket socket;
    tcp::resolver resolver;
    palp::wire::FrameDecoder decoder;
    std::array<std::uint8_t, 65536> read_buffer{};
    std::string out_pending, out_inflight;  // bytes to write / being written
    bool writing = false;
    bool connected = false;  // TCP up, Hello sent
    bool welcomed = false;
    std::int64_t started_ns = 0, last_rx_ns = 0;
    std::int64_t first_frame_ns = 0;         // arrival of the first frame (0: none yet)
    std::int64_t first_frame_server_ns = 0;  // its server_time_ns: force history t = 0
    std::int64_t last_history_server_ns = 0;
    std::uint64_t frames = 0;
    int pings = 0;
    std::int64_t last_ping_ns = 0;
    // Ping/Pong clock samples: round trip and offset (server - client), ns.
    std::deque<std::pair<std::int64_t, std::int64_t>> clock_samples;
    bool have_offset = false;
    std::int64_t offset_ns = 0, rtt_ns = 0;
    // Frames of the last second: (arrival ns, server_time_ns). Latency is computed from them
    // with the current offset, so every sample uses the best estimate.
    std::deque<std::pair<std::int64_t, std::int64_t>> arrivals;
    bool have_stats = false;
    std::uint64_t stats_sent = 0, stats_dropped = 0;
    std::array<std::int64_t, 3> scene_dims{};
    std::array<double, 3> scene_spacing{};
    bool have_scene = false;
    // Render volume being assembled.
    struct Assembly {
      bool active = false, done = false;
      std::uint32_t step = 0, chunk_count = 0, next_chunk = 0;
      std::int64_t next_k = 0;
      bool has_bone = false;
      std::shared_ptr<RenderVolume> volume;
    } assembly;
  };
  using ConnectionPtr = std::shared_ptr<Connection>;

  // What the render thread queues for the network thread.
  struct Outbox {
    std::optional<Pose> pose;
    std::deque<std::pair<std::uint64_t, std::string>> commands;  // request id, encoded frame
    bool wake_posted = false;
  };

  explicit Impl(const StreamOptions& o)
      : opts(o), retry_timer(io), house_timer(io), tick_ns(house_period_ns(o)) {}

  static std::int64_t house_period_ns(const StreamOptions& o) {
    const double s = std::clamp(o.stall_s / 4.0, 0.005, 0.05);
    return static_cast<std::int64_t>(s * 1e9);
  }

  // ------------------------------------------------------------------ lifecycle
  void start() {
    if (thread.joinable()) return;
    io.restart();
    stopping = false;
    refused = false;
    work.emplace(asio::make_work_guard(io));
    asio::post(io, [this] {
      start_connect();
      schedule_house();
    });
    thread = std::thread([this] {
      for (;;) {
        try {
          io.run();
          return;
        } catch (const std::exception& e) {  // a bug, not the server's doing: keep the thread
          if (conn) drop(conn, std::string("internal error: ") + e.what());
        }
      }
    });
  }

  void stop() {
    if (!thread.joinable()) return;
    asio::post(io, [this] {
      stopping = true;
      if (conn) close(*conn);
      conn.reset();
      retry_timer.cancel();
      house_timer.cancel();
      work.reset();  // run() returns once the cancelled handlers have run
    });
    thread.join();
    accept_commands.store(false);
    accept_poses.store(false);
  }

  // ------------------------------------------------------------------ connecting
  void start_connect() {
    if (stopping || refused) return;
    auto c = std::make_shared<Connection>(io);
    conn = c;
    c->started_ns = c->last_rx_ns = now_ns();
    c->resolver.async_resolve(
        opts.host, std::to_string(opts.port),
        [this, c](const asio::error_code& ec, const tcp::resolver::results_type& results) {
          if (c != conn) return;
          if (ec) {
            drop(c, "cannot resolve " + opts.host + ": " + ec.message());
            return;
          }
          asio::async_connect(
              c->socket, results, [this, c](const asio::error_code& e, const tcp::endpoint&) {
                if (c != conn) return;
                if (e) {
                  drop(c, "cannot connect to " + endpoint_text() + ": " + e.message());
                  return;
                }
                asio::error_code ignored;
                c->socket.set_option(tcp::no_delay(true), ignored);
                c->connected = true;
                c->last_rx_ns = now_ns();
                send_hello(*c);
                flush(c);
                read(c);
              });
        });
  }

  std::string endpoint_text() const {
    return (opts.host.find(':') != std::string::npos ? "[" + opts.host + "]" : opts.host) + ":" +
           std::to_string(opts.port);
  }

  void send_hello(Connection& c) {
    v1::ClientMessage m;
    v1::Hello* h = m.mutable_hello();
    h->set_protocol_version(palp::wire::kProtocolVersion);
    h->set_role(opts.controller ? v1::CONTROLLER : v1::OBSERVER);
    h->set_token(opts.token);
    h->set_client_name(opts.client_name);
    h->set_frame_rate_hz(opts.frame_rate_hz);
    h->set_volume_step(0);
    h->set_volume_max_dim(opts.volume_max_dim);
    h->set_want_contacts(opts.want_contacts);
    c.out_pending += palp::wire::encode_frame(m);
  }

  static void close(Connection& c) {
    asio::error_code ec;
    c.resolver.cancel();
    c.socket.shutdown(tcp::socket::shutdown_both, ec);
    c.socket.close(ec);
  }

  // The connection failed: Reconnecting, retry after the backoff delay.
  void drop(const ConnectionPtr& c, const std::string& why) {
    if (c != conn) return;
    close(*c);
    conn.reset();
    accept_poses.store(false);
    accept_commands.store(false);
    fail_queued_commands("not sent: " + why);
    if (stopping) return;
    const double delay =
        std::min(opts.reconnect_max_s, opts.reconnect_min_s * std::pow(2.0, std::min(attempt, 30)));
    ++attempt;
    {
      std::lock_guard lock(shared_mutex);
      shared.link.state = LinkState::Reconnecting;
      shared.link.message = why + "; retrying in " + seconds_text(delay);
      reset_rates_locked();
    }
    retry_timer.expires_after(std::chrono::nanoseconds(static_cast<std::int64_t>(delay * 1e9)));
    retry_timer.async_wait([this](const asio::error_code& ec) {
      if (ec || stopping) return;
      start_connect();
    });
  }

  // The server refused this client for good: Refused, no retry.
  void refuse(const ConnectionPtr& c, const std::string& why) {
    if (c != conn) return;
    close(*c);
    conn.reset();
    refused = true;
    accept_poses.store(false);
    accept_commands.store(false);
    fail_queued_commands("not sent: " + why);
    std::lock_guard lock(shared_mutex);
    shared.link.state = LinkState::Refused;
    shared.link.message = why;
    reset_rates_locked();
  }

  void reset_rates_locked() {
    shared.link.frames_per_s = 0;
    shared.link.latency_ms = -1;
  }

  // ------------------------------------------------------------------ reading
  void read(const ConnectionPtr& c) {
    c->socket.async_read_some(
        asio::buffer(c->read_buffer), [this, c](const asio::error_code& ec, std::size_t n) {
          if (c != conn) return;
          if (ec) {
            drop(c, ec == asio::error::eof ? "the server closed the connection"
                                           : "connection lost: " + ec.message());
            return;
          }
          const std::int64_t now = now_ns();
          c->last_rx_ns = now;
          c->decoder.feed(c->read_buffer.data(), n);
          std::string_view body;
          v1::ServerMessage message;
          for (;;) {
            const palp::wire::FrameStatus status = c->decoder.next(body);
            if (status == palp::wire::FrameStatus::Incomplete) break;
            if (status != palp::wire::FrameStatus::Ok) {
              drop(c, std::string("bad frame from the server: ") + palp::wire::to_string(status));
              return;
            }
            message.Clear();
            if (!message.ParseFromArray(body.data(), static_cast<int>(body.size()))) {
              drop(c, "undecodable message from the server");
              return;
            }
            try {
              on_message(c, message, now);
            } catch (const ProtocolViolation& e) {
              drop(c, std::string("protocol error: ") + e.what());
              return;
            } catch (const std::exception& e) {  // ResourceError (volume memory), bad_alloc
              drop(c, e.what());
              return;
            }
            if (c != conn) return;  // refused or dropped
          }
          read(c);
        });
  }

  void on_message(const ConnectionPtr& c, const v1::ServerMessage& m, std::int64_t now) {
    if (!c->welcomed && m.msg_case() != v1::ServerMessage::kWelcome &&
        m.msg_case() != v1::ServerMessage::kError)
      throw ProtocolViolation("the server sent something before its Welcome");
    switch (m.msg_case()) {
      case v1::ServerMessage::kWelcome:
        on_welcome(c, m.welcome(), now);
        return;
      case v1::ServerMessage::kScene:
        on_scene(*c, m.scene());
        return;
      case v1::ServerMessage::kVolume:
        on_volume(*c, m.volume());
        return;
      case v1::ServerMessage::kFrame:
        on_frame(*c, m.frame(), now);
        return;
      case v1::ServerMessage::kStats:
        on_stats(*c, m.stats());
        return;
      case v1::ServerMessage::kResult: {
        std::lock_guard lock(shared_mutex);
        shared.link.last_request_id = m.result().request_id();
        shared.link.last_result_ok = m.result().ok();
        shared.link.last_result_message = m.result().message();
        return;
      }
      case v1::ServerMessage::kError:
        on_error(c, m.error());
        return;
      case v1::ServerMessage::kPong:
        on_pong(*c, m.pong(), now);
        return;
      case v1::ServerMessage::MSG_NOT_SET:
        break;
    }
    // An empty envelope or a message type this client does not know (a newer server): ignored.
  }

  void on_welcome(const ConnectionPtr& c, const v1::Welcome& w, std::int64_t now) {
    if (c->welcomed) throw ProtocolViolation("a second Welcome");
    if (w.protocol_version() != palp::wire::kProtocolVersion) {
      refuse(c, "the server speaks protocol version " + std::to_string(w.protocol_version()) +
                    ", this client " + std::to_string(palp::wire::kProtocolVersion));
      return;
    }
    c->welcomed = true;
    attempt = 0;
    server_name = w.server_name();
    accept_commands.store(opts.controller);
    {
      std::lock_guard lock(shared_mutex);
      ++shared.link.connections;
      shared.connection = shared.link.connections;
      shared.scene = nullptr;
      shared.volume = nullptr;
      shared.frame = FrameState{};
      shared.force_history.clear();
      shared.link.state = LinkState::Loading;
      shared.link.message = "connected to " + (server_name.empty() ? "the server" : server_name) +
                            " at " + endpoint_text();
      shared.link.frames = 0;
      shared.link.delivered = -1;
      shared.link.rtt_ms = -1;
      shared.link.clock_offset_ms = 0;
      shared.link.volume_progress = opts.volume_max_dim > 0 ? 0.0 : 1.0;
      shared.link.server_tick_rate_hz = w.tick_rate_hz();
      reset_rates_locked();
    }
    ping(*c, now);
    flush(c);
  }

  void on_scene(Connection& c, const v1::SceneInfo& s) {
    const v1::Grid& g = s.grid();
    if (g.dims_size() != 3 || g.spacing_size() != 3)
      throw ProtocolViolation("SceneInfo: the grid needs 3 dims and 3 spacings");
    auto scene = std::make_shared<SceneDescription>();
    for (int a = 0; a < 3; ++a) {
      if (g.dims(a) < 1 || g.dims(a) > (std::int64_t{1} << 31))
        throw ProtocolViolation("SceneInfo: grid dimension " + std::to_string(g.dims(a)));
      if (!positive_finite(g.spacing(a)))
        throw ProtocolViolation("SceneInfo: grid spacing must be finite and > 0");
      scene->dims[a] = g.dims(a);
      scene->spacing[a] = g.spacing(a);
      if (g.origin_size() == 3) scene->origin[a] = g.origin(a);
    }
    if (g.direction_size() == 9)
      for (int i = 0; i < 9; ++i) scene->direction[i] = g.direction(i);
    if (c.have_scene && (scene->dims != c.scene_dims || scene->spacing != c.scene_spacing))
      throw ProtocolViolation("SceneInfo: the grid changed within a connection");
    c.have_scene = true;
    c.scene_dims = scene->dims;
    c.scene_spacing = scene->spacing;
    scene->source = s.source();
    for (const auto& [key, value] : s.metadata()) scene->metadata[key] = value;
    scene->tool = s.tool().name();
    scene->tool_points.reserve(static_cast<std::size_t>(s.tool().points_size()));
    for (const v1::Vec3& p : s.tool().points())
      scene->tool_points.push_back(palp::wire::from_proto(p));
    scene->c = s.parameters().c();
    scene->k = s.parameters().k();
    scene->bone_fmax = s.parameters().bone_fmax();
    scene->bone_enabled = s.parameters().bone_enabled();
    scene->device = s.device();
    scene->device_profile = s.device_profile();
    scene->tick_rate_hz = s.tick_rate_hz();
    scene->device_renders_force = s.device_renders_force();
    scene->server_name = server_name;
    std::lock_guard lock(shared_mutex);
    shared.scene = std::move(scene);
  }

  // Validates a chunk against the first one, the scene and the bytes present, then copies it in.
  void on_volume(Connection& c, const v1::VolumeChunk& chunk) {
    Connection::Assembly& a = c.assembly;
    const std::string where = "volume chunk " + std::to_string(chunk.chunk_index()) + ": ";
    const auto bad = [&](const std::string& why) { return ProtocolViolation(where + why); };
    if (chunk.dims_size() != 3 || chunk.spacing_size() != 3) throw bad("needs 3 dims and spacings");
    if (chunk.step() < 1) throw bad("step 0");
    if (chunk.chunk_count() < 1 || chunk.chunk_index() >= chunk.chunk_count())
      throw bad("index " + std::to_string(chunk.chunk_index()) + " of " +
                std::to_string(chunk.chunk_count()));
    if (opts.volume_max_dim == 0) throw bad("a render volume this client did not ask for");
    if (chunk.chunk_index() == 0) {
      if (a.active) throw bad("a new volume before the last one was complete");
      std::array<std::int64_t, 3> dims{};
      std::array<double, 3> spacing{};
      for (int i = 0; i < 3; ++i) {
        dims[i] = chunk.dims(i);
        spacing[i] = chunk.spacing(i);
        if (dims[i] < 1 || dims[i] > kMaxAxis)
          throw bad("dimension " + std::to_string(dims[i]) + " out of 1.." +
                    std::to_string(kMaxAxis));
        if (!positive_finite(spacing[i])) throw bad("spacing must be finite and > 0");
      }
      if (dims[0] * dims[1] * dims[2] > kMaxVoxels) throw bad("more than 2^28 voxels");
      if (chunk.chunk_count() > dims[2]) throw bad("more chunks than slices");
      if (c.have_scene)
        for (int i = 0; i < 3; ++i) {
          const std::int64_t expect = (c.scene_dims[i] + chunk.step() - 1) / chunk.step();
          if (dims[i] != expect)
            throw bad("dimension " + std::to_string(dims[i]) + " along axis " + std::to_string(i) +
                      ", the scene's grid at step " + std::to_string(chunk.step()) + " has " +
                      std::to_string(expect));
          const double sp = c.scene_spacing[i] * chunk.step();
          if (std::abs(spacing[i] - sp) > 1e-6 * sp) throw bad("spacing does not match the scene");
        }
      const std::size_t voxels = static_cast<std::size_t>(dims[0] * dims[1] * dims[2]);
      a = Connection::Assembly{};
      a.active = true;
      a.step = chunk.step();
      a.chunk_count = chunk.chunk_count();
      a.has_bone = !chunk.d_bone().empty();
      try {
        auto volume = std::make_shared<RenderVolume>();
        volume->dims = dims;
        volume->spacing = spacing;
        volume->step = chunk.step();
        volume->d_surf.resize(voxels);
        if (a.has_bone) volume->d_bone.resize(voxels);
        a.volume = std::move(volume);
      } catch (const std::bad_alloc&) {
        a = Connection::Assembly{};
        throw ResourceError("not enough memory for the render volume (" + std::to_string(voxels) +
                            " voxels)");
      }
    } else {
      if (!a.active) throw bad("without chunk 0");
      if (chunk.chunk_index() != a.next_chunk)
        throw bad("expected chunk " + std::to_string(a.next_chunk));
      if (chunk.step() != a.step || chunk.chunk_count() != a.chunk_count)
        throw bad("step or chunk count differs from chunk 0");
      for (int i = 0; i < 3; ++i)
        if (chunk.dims(i) != a.volume->dims[i] || chunk.spacing(i) != a.volume->spacing[i])
          throw bad("dims or spacing differ from chunk 0");
    }
    const RenderVolume& v = *a.volume;
    if (chunk.k_begin() != a.next_k)
      throw bad("k_begin " + std::to_string(chunk.k_begin()) + ", expected " +
                std::to_string(a.next_k));
    if (chunk.k_count() < 1 || chunk.k_begin() + std::int64_t{chunk.k_count()} > v.dims[2])
      throw bad("slices " + std::to_string(chunk.k_begin()) + "+" +
                std::to_string(chunk.k_count()) + " outside 0.." + std::to_string(v.dims[2]));
    const std::size_t slice = static_cast<std::size_t>(v.dims[0] * v.dims[1]);
    const std::size_t bytes = slice * chunk.k_count() * sizeof(float);
    if (chunk.d_surf().size() != bytes)
      throw bad("d_surf has " + std::to_string(chunk.d_surf().size()) + " bytes, expected " +
                std::to_string(bytes));
    if (chunk.d_bone().size() != (a.has_bone ? bytes : 0))
      throw bad("d_bone has " + std::to_string(chunk.d_bone().size()) + " bytes, expected " +
                std::to_string(a.has_bone ? bytes : 0));
    const std::size_t offset = slice * chunk.k_begin();
    copy_floats(chunk.d_surf(), a.volume->d_surf.data() + offset);
    if (a.has_bone) copy_floats(chunk.d_bone(), a.volume->d_bone.data() + offset);
    a.next_k += chunk.k_count();
    ++a.next_chunk;
    const bool complete = a.next_chunk == a.chunk_count;
    if (complete && a.next_k != v.dims[2])
      throw bad("the chunks cover " + std::to_string(a.next_k) + " of " +
                std::to_string(v.dims[2]) + " slices");
    std::lock_guard lock(shared_mutex);
    shared.link.volume_progress =
        static_cast<double>(a.next_k) / static_cast<double>(a.volume->dims[2]);
    if (complete) {
      shared.volume = std::move(a.volume);
      a = Connection::Assembly{};
      a.done = true;
    }
  }

  void on_frame(Connection& c, const v1::HapticFrame& f, std::int64_t now) {
    if (c.assembly.active) throw ProtocolViolation("a frame before the render volume was complete");
    FrameState frame;
    frame.valid = true;
    frame.seq = f.seq();
    frame.server_time_ns = f.server_time_ns();
    frame.pose = palp::wire::from_proto(f.device_pose());
    frame.force = palp::wire::from_proto(f.force());
    frame.torque = palp::wire::from_proto(f.torque());
    frame.u = palp::wire::from_proto(f.displacement());
    frame.n_contact = f.n_contact();
    frame.contact_points = f.contact_points();
    frame.contacts.reserve(static_cast<std::size_t>(f.contacts_size()));
    for (const v1::Contact& pc : f.contacts()) {
      ContactState cs;
      cs.x = palp::wire::from_proto(pc.position());
      cs.s = palp::wire::from_proto(pc.surface());
      cs.p = palp::wire::from_proto(pc.proxy());
      cs.f = palp::wire::from_proto(pc.force());
      cs.in_contact = pc.in_contact();
      frame.contacts.push_back(cs);
    }
    frame.tick_status = f.tick_status();
    frame.safety_status = f.safety_status();
    frame.fault = f.fault();
    frame.device_state = device_state_of(f.device_state());

    if (c.frames == 0) {
      c.first_frame_ns = now;
      c.first_frame_server_ns = f.server_time_ns();
      c.last_history_server_ns = f.server_time_ns() - kSecond;  // the first sample is kept
    }
    ++c.frames;
    c.arrivals.emplace_back(now, f.server_time_ns());
    while (c.arrivals.size() > 1 && c.arrivals.front().first < now - kSecond)
      c.arrivals.pop_front();
    // Force history, thinned so that at most force_history_max_samples cover force_history_s.
    const double min_gap_ns =
        opts.force_history_max_samples > 0
            ? opts.force_history_s * 1e9 / static_cast<double>(opts.force_history_max_samples)
            : 0.0;
    const bool keep_sample =
        opts.force_history_s > 0 &&
        static_cast<double>(f.server_time_ns() - c.last_history_server_ns) >= min_gap_ns;
    if (keep_sample) c.last_history_server_ns = f.server_time_ns();

    const bool was_live = accept_poses.load();
    std::lock_guard lock(shared_mutex);
    if (keep_sample) {
      ForceSample sample;
      sample.t_s = static_cast<double>(f.server_time_ns() - c.first_frame_server_ns) * 1e-9;
      sample.force = frame.force;
      history.push_back(sample);
      while (!history.empty() && history.front().t_s < sample.t_s - opts.force_history_s)
        history.pop_front();
    }
    shared.frame = std::move(frame);
    shared.link.frames = c.frames;
    last_frame_ns = now;
    if (shared.link.state != LinkState::Live) {
      if (shared.link.state == LinkState::Stalled) shared.link.message = "frames are back";
      shared.link.state = LinkState::Live;
    }
    if (!was_live) accept_poses.store(opts.controller);
  }

  void on_stats(Connection& c, const v1::Stats& s) {
    const std::uint64_t sent = s.client_frames_sent(), dropped = s.client_frames_dropped();
    double delivered = -2;  // unchanged
    if (!c.have_stats || sent < c.stats_sent || dropped < c.stats_dropped) {
      if (sent + dropped > 0)
        delivered = static_cast<double>(sent) / static_cast<double>(sent + dropped);
    } else {
      const std::uint64_t ds = sent - c.stats_sent, dd = dropped - c.stats_dropped;
      if (ds + dd > 0) delivered = static_cast<double>(ds) / static_cast<double>(ds + dd);
    }
    c.have_stats = true;
    c.stats_sent = sent;
    c.stats_dropped = dropped;
    std::lock_guard lock(shared_mutex);
    LinkStats& l = shared.link;
    if (delivered >= 0) l.delivered = delivered;
    l.server_tick_rate_hz = s.rate_hz();
    l.server_overruns = s.overruns();
    l.server_faults = s.faults();
    l.server_paused = s.paused();
    l.server_recording = s.recording();
    l.device_state = device_state_of(s.device_state());
    l.device_message = s.device_message();
  }

  void on_error(const ConnectionPtr& c, const v1::Error& e) {
    const std::string text = v1::Error::Code_Name(e.code()) + ": " + e.reason();
    if (e.fatal()) {
      if (is_refusal(e.code()))
        refuse(c, "refused by the server: " + text);
      else
        drop(c, "the server closed the connection: " + text);
      return;
    }
    std::lock_guard lock(shared_mutex);
    ++shared.link.server_errors;
    shared.link.message = "server: " + text;
  }

  void on_pong(Connection& c, const v1::Pong& p, std::int64_t now) {
    const std::int64_t sent = p.client_time_ns();
    if (sent < c.started_ns || sent > now) return;  // not one of this connection's Pings
    const std::int64_t rtt = now - sent;
    const std::int64_t offset = p.server_time_ns() - (sent + rtt / 2);
    c.clock_samples.emplace_back(rtt, offset);
    if (c.clock_samples.size() > kClockSamples) c.clock_samples.pop_front();
    const auto best = std::min_element(c.clock_samples.begin(), c.clock_samples.end());
    c.have_offset = true;
    c.rtt_ns = best->first;
    c.offset_ns = best->second;
    // LinkStats gets the offset together with the latency computed from it (housekeeping).
  }

  // ------------------------------------------------------------------ writing
  void ping(Connection& c, std::int64_t now) {
    v1::ClientMessage m;
    m.mutable_ping()->set_id(++ping_id);
    m.mutable_ping()->set_client_time_ns(now);
    c.out_pending += palp::wire::encode_frame(m);
    c.last_ping_ns = now;
    ++c.pings;
  }

  // Moves what the render thread queued into the connection and starts a write when none is in
  // flight. The newest pose is taken at the moment the socket can take it.
  void flush(const ConnectionPtr& c) {
    if (c != conn || !c->connected || c->writing) return;
    if (c->welcomed) {
      std::optional<Pose> pose;
      {
        std::lock_guard lock(outbox_mutex);
        for (auto& [id, bytes] : outbox.commands) c->out_pending += bytes;
        outbox.commands.clear();
        pose = std::exchange(outbox.pose, std::nullopt);
      }
      if (pose && accept_poses.load()) {
        v1::ClientMessage m;
        palp::wire::to_proto(*pose, m.mutable_device_pose()->mutable_pose());
        m.mutable_device_pose()->set_client_time_ns(now_ns());
        c->out_pending += palp::wire::encode_frame(m);
      }
    }
    if (c->out_pending.empty()) return;
    c->out_inflight.swap(c->out_pending);
    c->out_pending.clear();
    c->writing = true;
    asio::async_write(c->socket, asio::buffer(c->out_inflight),
                      [this, c](const asio::error_code& ec, std::size_t) {
                        c->writing = false;
                        if (c != conn) return;
                        if (ec) {
                          drop(c, "cannot send to the server: " + ec.message());
                          return;
                        }
                        flush(c);
                      });
  }

  // Render thread -> network thread.
  void wake() {
    {
      std::lock_guard lock(outbox_mutex);
      if (outbox.wake_posted) return;
      outbox.wake_posted = true;
    }
    asio::post(io, [this] {
      {
        std::lock_guard lock(outbox_mutex);
        outbox.wake_posted = false;
      }
      if (conn) flush(conn);
    });
  }

  void queue_pose(const Pose& pose) {
    if (!opts.controller || !accept_poses.load()) return;
    if (!is_finite(pose.position) || !std::isfinite(norm(pose.orientation))) return;
    {
      std::lock_guard lock(outbox_mutex);
      outbox.pose = pose;
    }
    wake();
  }

  std::uint64_t queue_command(v1::ClientMessage& m, const std::string& invalid) {
    if (!opts.controller) return 0;
    const std::uint64_t id = ++next_request_id;
    m.mutable_command()->set_request_id(id);
    std::string failure = invalid;
    if (failure.empty() && !accept_commands.load()) failure = "not sent: not connected";
    if (failure.empty()) {
      std::lock_guard lock(outbox_mutex);
      if (outbox.commands.size() >= opts.max_queued_commands)
        failure = "not sent: command queue full";
      else
        outbox.commands.emplace_back(id, palp::wire::encode_frame(m));
    }
    if (!failure.empty()) {
      record_result(id, false, failure);
      return id;
    }
    wake();
    return id;
  }

  void record_result(std::uint64_t id, bool ok, const std::string& message) {
    std::lock_guard lock(shared_mutex);
    shared.link.last_request_id = id;
    shared.link.last_result_ok = ok;
    shared.link.last_result_message = message;
  }

  void fail_queued_commands(const std::string& why) {
    std::deque<std::pair<std::uint64_t, std::string>> lost;
    {
      std::lock_guard lock(outbox_mutex);
      lost.swap(outbox.commands);
      outbox.pose.reset();
    }
    if (!lost.empty()) record_result(lost.back().first, false, why);
  }

  // ------------------------------------------------------------------ housekeeping
  void schedule_house() {
    house_timer.expires_after(std::chrono::nanoseconds(tick_ns));
    house_timer.async_wait([this](const asio::error_code& ec) {
      if (ec || stopping) return;
      housekeeping(now_ns());
      schedule_house();
    });
  }

  void housekeeping(std::int64_t now) {
    const ConnectionPtr c = conn;
    if (!c) return;
    if (opts.silence_timeout_s > 0 &&
        static_cast<double>(now - c->last_rx_ns) > opts.silence_timeout_s * 1e9) {
      drop(c, (c->welcomed ? "nothing from the server for " : "no answer from the server for ") +
                  seconds_text(opts.silence_timeout_s));
      return;
    }
    if (!c->welcomed) return;
    const std::int64_t ping_gap = c->pings < kFastPings ? kSecond / 10 : kSecond;
    if (now - c->last_ping_ns >= ping_gap) {
      ping(*c, now);
      flush(c);
    }
    while (!c->arrivals.empty() && c->arrivals.front().first < now - kSecond)
      c->arrivals.pop_front();
    double fps = 0;
    if (c->frames > 0) {
      const double window =
          std::clamp(static_cast<double>(now - c->first_frame_ns) * 1e-9, 0.25, 1.0);
      fps = static_cast<double>(c->arrivals.size()) / window;
    }
    latencies.clear();
    if (c->have_offset)
      for (const auto& [arrival, stamp] : c->arrivals)
        latencies.push_back(static_cast<double>(arrival + c->offset_ns - stamp) * 1e-6);
    double median = -1;
    if (!latencies.empty()) {
      const auto mid = latencies.begin() + static_cast<std::ptrdiff_t>(latencies.size() / 2);
      std::nth_element(latencies.begin(), mid, latencies.end());
      median = *mid;
    }
    std::lock_guard lock(shared_mutex);
    LinkStats& l = shared.link;
    l.frames_per_s = fps;
    l.latency_ms = median;
    if (c->have_offset) {
      l.rtt_ms = static_cast<double>(c->rtt_ns) * 1e-6;
      l.clock_offset_ms = static_cast<double>(c->offset_ns) * 1e-6;
    }
    if (l.state == LinkState::Live && c->frames > 0 &&
        static_cast<double>(now - last_frame_ns) > opts.stall_s * 1e9) {
      l.state = LinkState::Stalled;
      l.message = "no frame for " + seconds_text(opts.stall_s) + " or more";
      accept_poses.store(false);
    }
  }

  // ------------------------------------------------------------------ members
  const StreamOptions opts;
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

StreamClient::StreamClient(StreamOptions options) : options_(std::move(options)) {
  check_options(options_);
  impl_ = std::make_unique<Impl>(options_);
}

StreamClient::~StreamClient() {
  stop();
}

void StreamClient::start() {
  impl_->start();
}

void StreamClient::stop() {
  impl_->stop();
}

LatestState StreamClient::latest() const {
  const std::int64_t now = now_ns();
  std::lock_guard lock(impl_->shared_mutex);
  LatestState copy = impl_->shared;
  copy.force_history.assign(impl_->history.begin(), impl_->history.end());
  copy.link.since_last_frame_s =
      impl_->last_frame_ns > 0 ? static_cast<double>(now - impl_->last_frame_ns) * 1e-9 : 0.0;
  return copy;
}

void StreamClient::send_pose(const Pose& pose) {
  impl_->queue_pose(pose);
}

std::uint64_t StreamClient::set_tool(const std::string& tool) {
  v1::ClientMessage m;
  m.mutable_command()->mutable_set_tool()->set_tool(tool);
  return impl_->queue_command(m, tool.size() > kMaxNameBytes ? "tool name too long" : "");
}

std::uint64_t StreamClient::set_parameter(const std::string& name, double value) {
  v1::ClientMessage m;
  m.mutable_command()->mutable_set_parameter()->set_name(name);
  m.mutable_command()->mutable_set_parameter()->set_value(value);
  const char* invalid = name.size() > kMaxNameBytes ? "parameter name too long"
                        : !std::isfinite(value)     ? "parameter value must be finite"
                                                    : "";
  return impl_->queue_command(m, invalid);
}

std::uint64_t StreamClient::set_paused(bool paused) {
  v1::ClientMessage m;
  m.mutable_command()->mutable_pause()->set_paused(paused);
  return impl_->queue_command(m, "");
}

}  // namespace palp::view
