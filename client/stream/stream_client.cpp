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
//   start_connect -> resolve -> connect -> Hello -> read loop: messages decoded by the client
//   core's ServerMessageReader (proto/client_core/, as palp probe and palp ctl decode them) -> on_message (Welcome, SceneInfo, VolumeChunk, HapticFrame, Stats,
//   CommandResult, Pong, Error) -> shared state
//   housekeeping timer (every <= 50 ms): Pings, rates, latency median, Stalled, silence timeout
//   drop(): close, Reconnecting, retry after reconnect_min_s * 2^attempt (capped)
//
// This file: the connection, its thread, reading and writing, reconnecting and housekeeping.
// Elsewhere in stream/: Impl's declaration (stream_client_impl.hpp), the message handlers
// (server_messages.cpp) and the pure pieces they use, none of which sees Asio: handshake.*,
// volume_assembly.*, frame_decoding.*, clock_sync.*; HOST:PORT is in proto/client_core/host_port.*.
#include "stream/stream_client.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <optional>
#include <utility>

#include "asio.hpp"
#include "base/errors.hpp"
#include "client_core/host_port.hpp"
#include "stream/clock_sync.hpp"
#include "stream/handshake.hpp"
#include "stream/protocol_checks.hpp"
#include "stream/stream_client_impl.hpp"
#include "tls/client_policy.hpp"
#include "wire/messages.hpp"

namespace palp::view {

namespace v1 = palp::v1;

namespace {

using net::kSecond;
using net::now_ns;
using net::positive_finite;
using net::ProtocolViolation;

constexpr std::size_t kMaxNameBytes = palp::wire::kMaxNameBytes;

std::string seconds_text(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2g s", s);
  return text;
}

void check_options(const StreamOptions& o) {
  if (o.dds && o.controller) throw UsageError("stream client: over DDS only as an observer");
  if (o.host.empty() && !o.dds) throw UsageError("stream client: empty host");
  if (o.port == 0 && !o.dds) throw UsageError("stream client: port 0");
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
  palp::tls::check_client_options({o.tls_ca, o.tls_pin, o.tls_cert, o.tls_key});
}

bool speaks_tls(const StreamOptions& o) {
  return !o.tls_ca.empty() || !o.tls_pin.empty();
}

}  // namespace

std::int64_t StreamClient::Impl::house_period_ns(const StreamOptions& o) {
  const double s = std::clamp(o.stall_s / 4.0, 0.005, 0.05);
  return static_cast<std::int64_t>(s * 1e9);
}

// ------------------------------------------------------------------ lifecycle

void StreamClient::Impl::start() {
  if (thread.joinable()) return;
  if (opts.dds) {
    dds_stop = false;
    thread = std::thread([this] { run_dds(); });
    return;
  }
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

void StreamClient::Impl::stop() {
  if (!thread.joinable()) return;
  if (opts.dds) {
    dds_stop = true;
    thread.join();
    return;
  }
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

void StreamClient::Impl::start_connect() {
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
        // the token never leaves in clear text for another machine (tls/client_policy.hpp)
        if (const std::string no = palp::tls::clear_text_token_refusal(
                !opts.token.empty(), speaks_tls(opts), opts.host, results);
            !no.empty()) {
          refuse(c, no);
          return;
        }
        palp::tls::async_connect(c->stream, results, opts.host, std::to_string(opts.port),
                                 tls.get(), [this, c](const std::string& failure) {
                                   if (c != conn) return;
                                   if (!failure.empty()) {
                                     drop(c, failure);
                                     return;
                                   }
                                   c->connected = true;
                                   c->last_rx_ns = now_ns();
                                   send_hello(*c);
                                   flush(c);
                                   read(c);
                                 });
      });
}

std::string StreamClient::Impl::endpoint_text() const {
  return client::format_host_port(opts.host, opts.port);
}

void StreamClient::Impl::send_hello(Connection& c) {
  c.out_pending += net::encode_hello(opts);
}

void StreamClient::Impl::close(Connection& c) {
  c.resolver.cancel();
  c.stream.close();
}

void StreamClient::Impl::drop(const ConnectionPtr& c, const std::string& why) {
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

void StreamClient::Impl::refuse(const ConnectionPtr& c, const std::string& why) {
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

void StreamClient::Impl::reset_rates_locked() {
  shared.link.frames_per_s = 0;
  shared.link.latency_ms = -1;
}

// ------------------------------------------------------------------ reading

void StreamClient::Impl::read(const ConnectionPtr& c) {
  c->stream.async_read_some(
      asio::buffer(c->read_buffer), [this, c](const asio::error_code& ec, std::size_t n) {
        if (c != conn) return;
        if (ec) {
          drop(c, ec == asio::error::eof ? "the server closed the connection"
                                         : "connection lost: " + ec.message());
          return;
        }
        const std::int64_t now = now_ns();
        c->last_rx_ns = now;
        c->reader.feed(c->read_buffer.data(), n);
        v1::ServerMessage message;
        for (;;) {
          std::string why;
          const client::ServerMessageReader::Next next = c->reader.next(message, why);
          if (next == client::ServerMessageReader::Next::Incomplete) break;
          if (next == client::ServerMessageReader::Next::Broken) {
            drop(c, why);
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

// ------------------------------------------------------------------ writing

void StreamClient::Impl::ping(Connection& c, std::int64_t now) {
  v1::ClientMessage m;
  m.mutable_ping()->set_id(++ping_id);
  m.mutable_ping()->set_client_time_ns(now);
  c.out_pending += palp::wire::encode_frame(m);
  c.last_ping_ns = now;
  ++c.pings;
}

void StreamClient::Impl::flush(const ConnectionPtr& c) {
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
  c->stream.async_write(asio::buffer(c->out_inflight),
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

void StreamClient::Impl::wake() {
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

void StreamClient::Impl::queue_pose(const Pose& pose) {
  if (!opts.controller || !accept_poses.load()) return;
  if (!is_finite(pose.position) || !std::isfinite(norm(pose.orientation))) return;
  {
    std::lock_guard lock(outbox_mutex);
    outbox.pose = pose;
  }
  wake();
}

std::uint64_t StreamClient::Impl::queue_command(v1::ClientMessage& m, const std::string& invalid) {
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

void StreamClient::Impl::record_result(std::uint64_t id, bool ok, const std::string& message) {
  std::lock_guard lock(shared_mutex);
  shared.link.last_request_id = id;
  shared.link.last_result_ok = ok;
  shared.link.last_result_message = message;
}

void StreamClient::Impl::fail_queued_commands(const std::string& why) {
  std::deque<std::pair<std::uint64_t, std::string>> lost;
  {
    std::lock_guard lock(outbox_mutex);
    lost.swap(outbox.commands);
    outbox.pose.reset();
  }
  if (!lost.empty()) record_result(lost.back().first, false, why);
}

// ------------------------------------------------------------------ housekeeping

void StreamClient::Impl::schedule_house() {
  house_timer.expires_after(std::chrono::nanoseconds(tick_ns));
  house_timer.async_wait([this](const asio::error_code& ec) {
    if (ec || stopping) return;
    housekeeping(now_ns());
    schedule_house();
  });
}

void StreamClient::Impl::housekeeping(std::int64_t now) {
  const ConnectionPtr c = conn;
  if (!c) return;
  if (opts.silence_timeout_s > 0 &&
      static_cast<double>(now - c->last_rx_ns) > opts.silence_timeout_s * 1e9) {
    drop(c, (c->welcomed ? "nothing from the server for " : "no answer from the server for ") +
                seconds_text(opts.silence_timeout_s));
    return;
  }
  if (!c->welcomed) return;
  if (now - c->last_ping_ns >= net::ping_gap_ns(c->pings)) {
    ping(*c, now);
    flush(c);
  }
  while (!c->arrivals.empty() && c->arrivals.front().first < now - kSecond) c->arrivals.pop_front();
  double fps = 0;
  if (c->frames > 0) {
    const double window =
        std::clamp(static_cast<double>(now - c->first_frame_ns) * 1e-9, 0.25, 1.0);
    fps = static_cast<double>(c->arrivals.size()) / window;
  }
  const double median = net::median_latency_ms(c->arrivals, c->clock, latencies);
  std::lock_guard lock(shared_mutex);
  LinkStats& l = shared.link;
  l.frames_per_s = fps;
  l.latency_ms = median;
  if (c->clock.have_offset()) {
    l.rtt_ms = static_cast<double>(c->clock.rtt_ns()) * 1e-6;
    l.clock_offset_ms = static_cast<double>(c->clock.offset_ns()) * 1e-6;
  }
  if (l.state == LinkState::Live && c->frames > 0 &&
      static_cast<double>(now - last_frame_ns) > opts.stall_s * 1e9) {
    l.state = LinkState::Stalled;
    l.message = "no frame for " + seconds_text(opts.stall_s) + " or more";
    accept_poses.store(false);
  }
}

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

std::uint64_t StreamClient::recentre() {
  v1::ClientMessage m;
  m.mutable_command()->mutable_recentre();
  return impl_->queue_command(m, "");
}

std::uint64_t StreamClient::start_recording(const std::string& name) {
  v1::ClientMessage m;
  m.mutable_command()->mutable_start_recording()->set_name(name);
  return impl_->queue_command(m, "");
}

std::uint64_t StreamClient::stop_recording() {
  v1::ClientMessage m;
  m.mutable_command()->mutable_stop_recording();
  return impl_->queue_command(m, "");
}

std::uint64_t StreamClient::task_mark() {
  v1::ClientMessage m;
  m.mutable_command()->mutable_task_mark();
  return impl_->queue_command(m, "");
}

std::string connect_refusal(const StreamOptions& o) {
  if (o.dds || o.token.empty()) return "";
  asio::io_context io;
  asio::ip::tcp::resolver resolver(io);
  asio::error_code ec;
  const auto endpoints = resolver.resolve(o.host, std::to_string(o.port), ec);
  if (ec) return "";  // the network thread says why, and retries
  return palp::tls::clear_text_token_refusal(true, speaks_tls(o), o.host, endpoints);
}

}  // namespace palp::view
