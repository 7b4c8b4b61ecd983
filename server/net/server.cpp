// The palpd network server: see server.hpp. Everything below runs on the io thread except the
// constructor, start(), stop() and the atomic counters.
#include "net/server.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <map>
#include <thread>
#include <vector>

#include "asio.hpp"
#include "base/errors.hpp"
#include "net/admission.hpp"
#include "net/client_log.hpp"
#include "net/client_queue.hpp"
#include "net/force_history.hpp"
#include "net/listen_check.hpp"
#include "net/protocol.hpp"
#include "net/scene_messages.hpp"
#include "net/session.hpp"
#include "net/task_messages.hpp"
#include "net/tls_accept.hpp"
#include "net/token_guard.hpp"
#include "net/volume_cache.hpp"
#include "wire/framing.hpp"

namespace palp::net {

using asio::ip::tcp;

namespace {

std::int64_t seconds_to_ns(double s) {
  return static_cast<std::int64_t>(s * 1e9);
}

}  // namespace

class Server::Impl {
 public:
  Impl(ServerConfig config, SceneDescription scene, rt::HapticLoop& loop, ControlTarget* control)
      : config_(std::move(config)),
        scene_(std::move(scene)),
        loop_(loop),
        control_(control),
        acceptor_(io_),
        pump_(io_, loop.net_ring(), loop.net_signal(), config_.net_wake, config_.poll_interval_s,
              [this] { frames_published(); }),
        house_timer_(io_) {
    bind_acceptor(acceptor_, config_.bind, config_.port);
    asio::error_code ec;
    acceptor_.listen(asio::socket_base::max_listen_connections, ec);
    if (ec)
      throw ResourceError("cannot listen on " + config_.bind + ":" + std::to_string(config_.port) +
                          ": " + ec.message());
    port_ = acceptor_.local_endpoint().port();
  }

  ~Impl() { stop(); }

  void start() {
    if (thread_.joinable()) return;
    last_stats_ns_ = rt::monotonic_ns();
    last_stats_ticks_ = loop_.stats().ticks;
    accept();
    pump_.start();
    schedule_house();
    thread_ = std::thread([this] {
      if (config_.cpu >= 0) rt::pin_this_thread(config_.cpu);  // checked by palpd's options
      io_.run();
    });
  }

  void stop() {
    if (!thread_.joinable()) return;
    asio::post(io_, [this] {
      asio::error_code ec;
      acceptor_.close(ec);
      pump_.stop();
      house_timer_.cancel();
      for (auto& s : sessions_) close(*s);
      sessions_.clear();
      io_.stop();
    });
    thread_.join();
    client_count_.store(0);
  }

  void scene_changed() {
    asio::post(io_, [this] { scene_dirty_ = true; });
  }
  struct Tap {
    std::function<void(const rt::Snapshot&)> offer;
    FrameSchedule frames;
  };
  std::vector<Tap> taps_;  // added before start()

  std::uint16_t port() const { return port_; }
  std::size_t client_count() const { return client_count_.load(); }
  ServerCounters counters() const {
    return {accepted_.load(),       rejected_.load(), protocol_errors_.load(), frames_sent_.load(),
            frames_dropped_.load(), timeouts_.load(), overflows_.load(),       pump_.wakeups()};
  }

  using Session = ServerSession;
  using SessionPtr = std::shared_ptr<Session>;

 private:
  // ------------------------------------------------------------------ accept
  void accept() {
    auto session = std::make_shared<Session>(io_, config_);
    acceptor_.async_accept(session->stream.socket(), [this, session](const asio::error_code& ec) {
      if (ec) {
        if (ec != asio::error::operation_aborted && acceptor_.is_open()) accept();
        return;
      }
      on_accept(session);
      accept();
    });
  }

  void on_accept(const SessionPtr& s) {
    asio::error_code ec;
    s->stream.socket().set_option(tcp::no_delay(true), ec);
    if (config_.send_buffer_bytes > 0)
      s->stream.socket().set_option(asio::socket_base::send_buffer_size(config_.send_buffer_bytes),
                                    ec);
    s->id = ++next_id_;
    s->connected_ns = s->last_rx_ns = rt::monotonic_ns();
    const tcp::endpoint remote = s->stream.socket().remote_endpoint(ec);
    s->address = ec ? std::string("?") : remote.address().to_string();
    accepted_.fetch_add(1);
    std::erase_if(sessions_, [](const SessionPtr& other) { return other->closed; });
    // Before Hello a connection counts against the pending budgets, not against max_clients.
    std::size_t pending = 0, pending_here = 0;
    for (const SessionPtr& other : sessions_) {
      if (other->welcomed || other->closing || other->closed) continue;
      ++pending;
      if (other->address == s->address) ++pending_here;
    }
    sessions_.push_back(s);
    client_count_.store(sessions_.size());
    s->refusal = pending_refusal(config_, s->address, pending, pending_here);
    if (!s->refusal.empty() && !config_.tls)
      return fatal(s, v1::Error::TOO_MANY_CLIENTS, s->refusal);
    if (!config_.tls) return read(s);
    s->handshaking = true;
    tls_accept(s->stream, *config_.tls, [this, s](const TlsAccepted& r) {
      s->handshaking = false;
      if (!r.notice.empty()) log_client(r.notice);
      if (s->closed) return;
      if (r.kind == TlsAccepted::Kind::PlainText)
        return fatal(s, v1::Error::UNAUTHORIZED, plain_text_refusal());
      if (r.kind == TlsAccepted::Kind::Failed) {
        log_client(who(*s) + " refused: " + r.message);
        s->end_logged = true;
        return close(*s);
      }
      s->cert = r.client;
      if (!s->refusal.empty()) return fatal(s, v1::Error::TOO_MANY_CLIENTS, s->refusal);
      read(s);
    });
  }

  // ------------------------------------------------------------------ read
  void read(const SessionPtr& s) {
    if (s->closing || s->closed || s->reading) return;
    s->reading = true;
    s->stream.async_read_some(
        asio::buffer(s->rbuf), [this, s](const asio::error_code& ec, std::size_t n) {
          s->reading = false;
          if (s->closed) return;
          if (ec) {
            close(*s);
            return;
          }
          s->last_rx_ns = rt::monotonic_ns();
          s->decoder.feed(s->rbuf.data(), n);
          std::string_view body;
          for (;;) {
            const wire::FrameStatus status = s->decoder.next(body);
            if (status == wire::FrameStatus::Incomplete) break;
            if (status == wire::FrameStatus::TooLarge) {
              fatal(s, v1::Error::FRAME_TOO_LARGE,
                    "frame larger than " + std::to_string(config_.max_frame_bytes) + " bytes");
              return;
            }
            if (status == wire::FrameStatus::BadPrefix) {
              fatal(s, v1::Error::MALFORMED, "bad length prefix");
              return;
            }
            handle(s, body);
            if (s->closing || s->closed) return;
          }
          read(s);
        });
  }

  void handle(const SessionPtr& s, std::string_view body) {
    v1::ClientMessage msg;
    const ClientCheck check = parse_client_message(body, msg);
    if (!s->welcomed) {
      if (!check.ok) {
        fatal(s, check.code, check.reason);
        return;
      }
      if (msg.msg_case() != v1::ClientMessage::kHello) {
        fatal(s, v1::Error::EXPECTED_HELLO, "the first message must be a Hello");
        return;
      }
      hello(s, msg.hello());
      return;
    }
    if (!check.ok) {
      error(s, check.code, check.reason);
      return;
    }
    switch (msg.msg_case()) {
      case v1::ClientMessage::kHello:
        error(s, v1::Error::BAD_REQUEST, "Hello was already received");
        return;
      case v1::ClientMessage::kPing:
        send(s, pong_frame(msg.ping(), rt::monotonic_ns()));
        return;
      case v1::ClientMessage::kCommand:
        if (s->role != v1::CONTROLLER) {
          error(s, v1::Error::PERMISSION_DENIED, "observers cannot send commands");
          return;
        }
        command(s, msg.command());
        return;
      case v1::ClientMessage::kDevicePose:
        if (s->role != v1::CONTROLLER) {
          error(s, v1::Error::PERMISSION_DENIED, "observers cannot drive the device");
          return;
        }
        if (!control_ || !control_->set_device_pose(wire::from_proto(msg.device_pose().pose()),
                                                    rt::monotonic_ns()))
          error(s, v1::Error::BAD_REQUEST, "the device is not remote");
        return;
      case v1::ClientMessage::MSG_NOT_SET:
        break;
    }
  }

  void hello(const SessionPtr& s, const v1::Hello& h) {
    HelloFacts facts{&s->cert, s->stream.secure(), s->address};
    for (const SessionPtr& other : sessions_) {
      if (other == s || other->closed) continue;
      if (other->role == v1::CONTROLLER)
        facts.controller_taken = true;
      else if (other->welcomed && !other->closing)
        ++facts.observers;
    }
    if (auto no = check_hello(h, facts, config_, token_guard_, rt::monotonic_ns())) {
      if (no->token_refused) {
        if (config_.log_clients)
          token_log_.say(std::string(h.token().empty() ? "no" : "wrong") +
                         " controller token from " + s->address + " (" +
                         std::to_string(token_guard_.total()) + " refused in all so far)");
        s->end_logged = true;  // said just above
      }
      return fatal(s, no->code, no->reason);
    }
    s->welcomed = true;
    s->role = h.role();
    s->name = h.client_name();
    s->want_contacts = h.want_contacts();
    s->frames.interval_ns = frame_interval_ns(h.frame_rate_hz());
    drain();  // the loop wakes this thread only for due frames: take what the ring holds first
    v1::ServerMessage history;  // the force before it came, after SceneInfo (force_history.hpp)
    force_history_.fill(history.mutable_history());
    s->history = frame_of(history);
    if (!queue(*s, welcome_frame(s->id, s->role, config_.server_name, loop_.config().rate_hz,
                                 rt::monotonic_ns())) ||
        !queue_scene(*s, scene_frame()))
      return;
    if (TaskSession* t = task()) queue_task(*s, *t);
    plan_volume(*s, {h.volume_step(), h.volume_max_dim(), h.volume_hu(), !h.volume_skip_bone(),
                     h.volume_deflate(), h.volume_crop(), h.volume_labels()});
    if (s->volume.chunks == 0) became_ready(*s);
    log_client(who(*s) + " joined");
    pump(s);
  }

  // ------------------------------------------------------------------ the log
  void log_client(const std::string& line) {
    if (config_.log_clients) client_log_.say(line);
  }
  static std::string who(const Session& s) {
    return describe_client(s.id, s.address, s.welcomed, s.role == v1::CONTROLLER,
                           s.cert.verified ? s.name + " [" + s.cert.subject + "]" : s.name);
  }

  void command(const SessionPtr& s, const v1::Command& c) {
    bool scene_change = false;
    const std::string failure = apply_command(control_, c, who(*s), scene_change);
    v1::ServerMessage m;
    v1::CommandResult* r = m.mutable_result();
    r->set_request_id(c.request_id());
    r->set_ok(failure.empty());
    r->set_message(failure);
    send(s, frame_of(m));
    if (scene_change) scene_dirty_ = true;  // sent at the next poll, once for a burst of changes
    if (is_task_command(c)) send_task_to_all();
  }

  // The training task: TaskStatus to each client as its role may see it (task_messages.hpp).
  TaskSession* task() { return control_ ? control_->task() : nullptr; }
  bool queue_task(Session& s, const TaskSession& t) {
    for (Bytes& b : task_frames(t, s.role == v1::CONTROLLER, s.landmarks_sent))
      if (!queue(s, std::move(b))) return false;
    return true;
  }
  void send_task_to_all() {
    if (TaskSession* t = task()) {
      task_revision_ = t->revision();
      for (const SessionPtr& s : sessions_)
        if (s->welcomed && !s->closing && !s->closed && queue_task(*s, *t)) pump(s);
    }
  }

  // One SceneInfo, shared by every welcomed client; it replaces one still queued for a client.
  void send_scene_to_all() {
    scene_dirty_ = false;
    const Bytes scene = scene_frame();
    for (const SessionPtr& s : sessions_)
      if (s->welcomed && !s->closing && !s->closed && queue_scene(*s, scene)) pump(s);
  }

  // ------------------------------------------------------------------ scene and volume
  Bytes scene_frame() {
    v1::ServerMessage m;
    fill_scene_info(scene_, loop_, m.mutable_scene());
    return frame_of(m);
  }

  void plan_volume(Session& s, const VolumeRequest& r) {
    if (!scene_.fields || (r.step == 0 && r.max_dim == 0)) return;
    s.volume = volume_cache_.plan(r);
    if (s.volume.chunks > 0) s.volume_frames = volume_cache_.get(s.volume);
  }

  Bytes next_volume_chunk(Session& s) {  // null: not encoded yet (volume_cache_ wakes us)
    Bytes b = s.volume_frames->frame(s.volume_chunk);
    if (b && ++s.volume_chunk == s.volume.chunks) became_ready(s);
    if (s.ready) s.volume_frames.reset();
    return b;
  }

  // ------------------------------------------------------------------ write
  void pump(const SessionPtr& s) {
    if (s->writing || s->closed) return;
    s->inflight.clear();
    s->buffers.clear();
    std::size_t frames_now = 0;
    s->queue.take(s->inflight, false);
    if (s->history) s->inflight.push_back(std::exchange(s->history, nullptr));
    if (!s->closing && !s->ready && s->volume.chunks > 0 && s->inflight.empty())
      if (Bytes b = next_volume_chunk(*s)) s->inflight.push_back(std::move(b));
    if (!s->closing && s->ready) frames_now = s->queue.take(s->inflight, true);
    if (s->inflight.empty()) {
      if (s->closing) close(*s);
      return;
    }
    for (const Bytes& b : s->inflight) s->buffers.push_back(asio::buffer(*b));
    s->writing = true;
    s->write_started_ns = rt::monotonic_ns();
    s->stream.async_write(s->buffers,
                          [this, s, frames_now](const asio::error_code& ec, std::size_t) {
                            s->writing = false;
                            if (s->closed) return;
                            if (ec) {
                              close(*s);
                              return;
                            }
                            s->frames_sent += frames_now;
                            frames_sent_.fetch_add(frames_now);
                            pump(s);
                          });
  }

  // Queue a message / replace the queued SceneInfo for `s`; false (and the client dropped) when
  // its queue exceeds max_queue_bytes even after its stale frames went.
  bool queue(Session& s, Bytes bytes) {
    if (s.closed) return false;
    return counted(s, s.queue.push_message(std::move(bytes)));
  }

  bool queue_scene(Session& s, Bytes scene) {
    if (s.closed) return false;
    return counted(s, s.queue.push_scene(std::move(scene)));
  }

  // Adds the frames the queue dropped to the server's count; drops the client when its queue
  // is over the bound.
  bool counted(Session& s, bool within_bound) {
    const std::uint64_t dropped = s.queue.frames_dropped();
    frames_dropped_.fetch_add(dropped - s.frames_dropped_counted);
    s.frames_dropped_counted = dropped;
    if (within_bound) return true;
    overflows_.fetch_add(1);
    // an Error could not get through a queue the client does not read either
    close(s, "dropped: its queue is over --queue-bytes (it does not read)");
    return false;
  }

  void send(const SessionPtr& s, Bytes bytes) {
    if (queue(*s, std::move(bytes))) pump(s);
  }

  void error(const SessionPtr& s, v1::Error::Code code, const std::string& reason) {
    protocol_errors_.fetch_add(1);
    send(s, error_frame(code, reason, false));
  }

  void fatal(const SessionPtr& s, v1::Error::Code code, const std::string& reason) {
    if (!s->end_logged) log_client(who(*s) + (s->welcomed ? " dropped: " : " refused: ") + reason);
    s->end_logged = true;
    protocol_errors_.fetch_add(1);
    rejected_.fetch_add(1);
    s->queue.drop_frames();
    counted(*s, true);
    s->closing = true;
    send(s, error_frame(code, reason, true));
  }

  // Closes the socket; the queue goes to the graveyard, freed a slice at a time (each poll).
  void close(Session& s, const char* why = "left") {
    if (s.closed) return;
    s.closed = true;
    if (!s.end_logged && s.welcomed) log_client(who(s) + " " + why);
    s.end_logged = true;
    s.stream.close();
    s.queue.bury(graveyard_);
  }

  // ------------------------------------------------------------------ frames from the loop
  // Run by the frame pump (frame_pump.hpp) whenever the loop woke it, and on its backstop.
  void frames_published() {
    if (scene_dirty_) send_scene_to_all();
    drain();
    if (task() && task()->revision() != task_revision_) send_task_to_all();  // a button's mark
    want_frames();
    graveyard_.free_some(kFreePerPoll);
  }

  // Tells the loop the earliest snapshot time a client or a tap takes next (before the pump
  // arms: frame_pump.hpp), so it wakes this thread for that tick and not for every one (issue 41).
  void want_frames() {
    std::int64_t due = rt::WakeSignal::kNobody;
    for (const SessionPtr& s : sessions_)
      if (s->ready && !s->closing && !s->closed) due = std::min(due, s->frames.due());
    for (const Tap& tap : taps_) due = std::min(due, tap.frames.due());
    loop_.net_signal().want_from(due);
  }

  // Frames flow to `s` from the next snapshot on: the loop is told at once.
  void became_ready(Session& s) {
    s.ready = true;
    loop_.net_signal().want_from(std::min(loop_.net_signal().wanted_from(), s.frames.due()));
  }

  void drain() {
    // A device that comes or goes is told at once (Stats), not at the next stats interval.
    const rt::DeviceState device_state = loop_.device_state();
    if (device_state != last_device_state_) {
      last_device_state_ = device_state;
      send_stats(rt::monotonic_ns());
    }
    rt::SnapshotRing& ring = loop_.net_ring();
    std::vector<SessionPtr> touched;
    while (const rt::Snapshot* snap = ring.front()) {
      Bytes plain, full;
      const std::int64_t t = snap->tick.t_ns;
      for (const SessionPtr& s : sessions_) {
        if (!s->ready || s->closing || s->closed) continue;
        if (!s->frames.take(t)) continue;
        Bytes& bytes = s->want_contacts ? full : plain;
        if (!bytes) {
          v1::ServerMessage m;
          fill_frame(*snap, s->want_contacts, m.mutable_frame());
          bytes = frame_of(m);
        }
        s->queue.push_frame(bytes);
        counted(*s, true);
        if (std::find(touched.begin(), touched.end(), s) == touched.end()) touched.push_back(s);
      }
      for (Tap& tap : taps_) {
        tap.frames.take(t);  // its own rate, to know when it is due (the tap applies it too)
        tap.offer(*snap);
      }
      force_history_.add(snap->tick.t_ns, snap->tick.force);
      ring.pop();
    }
    for (const SessionPtr& s : touched) pump(s);
  }

  // ------------------------------------------------------------------ housekeeping
  void schedule_house() {
    house_timer_.expires_after(std::chrono::milliseconds(50));
    house_timer_.async_wait([this](const asio::error_code& ec) {
      if (ec) return;
      housekeeping();
      schedule_house();
    });
  }

  void housekeeping() {
    const std::int64_t now = rt::monotonic_ns();
    for (const SessionPtr& s : sessions_) {
      if (s->closed) continue;
      const bool stalled_write = s->writing && config_.write_timeout_s > 0 &&
                                 now - s->write_started_ns > seconds_to_ns(config_.write_timeout_s);
      if (stalled_write) {
        timeouts_.fetch_add(1);
        // the socket does not drain: an Error could not get through either
        close(*s, "dropped: its socket did not drain within --write-timeout");
        continue;
      }
      if (s->closing) continue;
      if (!s->welcomed && now - s->connected_ns > seconds_to_ns(config_.hello_timeout_s)) {
        timeouts_.fetch_add(1);
        if (s->handshaking)
          close(*s, "refused: no TLS handshake in time");
        else
          fatal(s, v1::Error::TIMEOUT, "no Hello received in time");
        continue;
      }
      if (config_.idle_timeout_s > 0 &&
          now - s->last_rx_ns > seconds_to_ns(config_.idle_timeout_s)) {
        timeouts_.fetch_add(1);
        fatal(s, v1::Error::TIMEOUT, "nothing received for too long (send Ping)");
        continue;
      }
    }
    std::erase_if(sessions_, [](const SessionPtr& s) { return s->closed; });
    client_count_.store(sessions_.size());
    if (now - last_stats_ns_ >= seconds_to_ns(config_.stats_interval_s)) send_stats(now);
  }

  void send_stats(std::int64_t now) {
    const rt::LoopStats ls = loop_.stats();
    const double dt = static_cast<double>(now - last_stats_ns_) * 1e-9;
    const double rate = dt > 0 ? static_cast<double>(ls.ticks - last_stats_ticks_) / dt : 0.0;
    last_stats_ns_ = now;
    last_stats_ticks_ = ls.ticks;
    v1::ServerMessage m;
    v1::Stats* st = m.mutable_stats();
    fill_stats(ls, loop_, scene_, control_, rate, now, static_cast<std::uint32_t>(sessions_.size()),
               st);
    for (const SessionPtr& s : sessions_)
      if (s->role == v1::CONTROLLER && s->welcomed && !s->closed) st->set_controller(who(*s));
    for (const SessionPtr& s : sessions_) {
      if (!s->welcomed || s->closing || s->closed) continue;
      st->set_client_frames_sent(s->frames_sent);
      st->set_client_frames_dropped(s->queue.frames_dropped());
      send(s, frame_of(m));
    }
  }

  ServerConfig config_;
  SceneDescription scene_;
  rt::HapticLoop& loop_;
  ControlTarget* control_;
  asio::io_context io_;
  tcp::acceptor acceptor_;
  FramePump pump_;
  asio::steady_timer house_timer_;
  std::thread thread_;
  std::vector<SessionPtr> sessions_;
  // Queues of dropped clients, freed kFreePerPoll messages per poll.
  static constexpr std::size_t kFreePerPoll = 4096;
  Graveyard graveyard_;
  bool scene_dirty_ = false;         // the scene changed since SceneInfo was last sent
  std::uint64_t task_revision_ = 0;  // the task's revision last sent
  std::uint16_t port_ = 0;
  std::uint64_t next_id_ = 0;
  TokenGuard token_guard_;
  std::int64_t last_stats_ns_ = 0;
  rt::DeviceState last_device_state_ = rt::DeviceState::Present;
  std::uint64_t last_stats_ticks_ = 0;
  std::atomic<std::size_t> client_count_{0};
  std::atomic<std::uint64_t> accepted_{0}, rejected_{0}, protocol_errors_{0}, frames_sent_{0},
      frames_dropped_{0}, timeouts_{0}, overflows_{0};
  // token refusals have a budget of their own, so a flood of other refusals cannot hide them
  ClientLog client_log_, token_log_;
  ForceHistory force_history_;
  // Last: its encoders stop before anything they post to. Wakes the sessions waiting for a chunk.
  VolumeCache volume_cache_{scene_, config_.volume_chunk_bytes,
                            [this] {
                              asio::post(io_, [this] {
                                for (const SessionPtr& s : sessions_)
                                  if (!s->ready && s->volume_frames && !s->writing) pump(s);
                              });
                            },
                            true};
};

Server::Server(ServerConfig config, SceneDescription scene, rt::HapticLoop& loop,
               ControlTarget* control)
    : impl_(std::make_unique<Impl>(std::move(config), std::move(scene), loop, control)) {}
Server::~Server() {
  stop();
}
std::uint16_t Server::port() const {
  return impl_->port();
}

void Server::start() {
  impl_->start();
}
void Server::stop() {
  impl_->stop();
}
std::size_t Server::client_count() const {
  return impl_->client_count();
}
ServerCounters Server::counters() const {
  return impl_->counters();
}
void Server::add_snapshot_tap(std::function<void(const rt::Snapshot&)> tap, double rate_hz) {
  impl_->taps_.push_back({std::move(tap), FrameSchedule{frame_interval_ns(rate_hz), 0}});
}
void Server::scene_changed() {
  impl_->scene_changed();
}

}  // namespace palp::net
