// The palpd network server (server.hpp): construction, start and stop, and the reading side:
// accepting clients, reading their messages, the Hello handshake and commands. The write side is
// in server_send.cpp, what goes out unasked (frames, scene, volume, task, Stats) and the
// housekeeping in server_frames.cpp; Server::Impl is declared in server_impl.hpp. Everything
// below runs on the io thread except the constructor, start(), stop() and the atomic counters.
#include "net/server.hpp"

#include <string>
#include <thread>

#include "asio.hpp"
#include "base/errors.hpp"
#include "net/admission.hpp"
#include "net/listen_check.hpp"
#include "net/protocol.hpp"
#include "net/scene_messages.hpp"
#include "net/server_impl.hpp"
#include "net/task_messages.hpp"
#include "net/tls_accept.hpp"
#include "wire/framing.hpp"

namespace palp::net {

using asio::ip::tcp;

Server::Impl::Impl(ServerConfig config, SceneDescription scene, rt::HapticLoop& loop,
                   ControlTarget* control)
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

void Server::Impl::start() {
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

void Server::Impl::stop() {
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

// ------------------------------------------------------------------ accept
void Server::Impl::accept() {
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

void Server::Impl::on_accept(const SessionPtr& s) {
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
  if (!s->refusal.empty() && !config_.tls) return fatal(s, v1::Error::TOO_MANY_CLIENTS, s->refusal);
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
void Server::Impl::read(const SessionPtr& s) {
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

void Server::Impl::handle(const SessionPtr& s, std::string_view body) {
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

void Server::Impl::hello(const SessionPtr& s, const v1::Hello& h) {
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
        token_log_.say(std::string(h.token().empty() ? "no" : "wrong") + " controller token from " +
                       s->address + " (" + std::to_string(token_guard_.total()) +
                       " refused in all so far)");
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

void Server::Impl::command(const SessionPtr& s, const v1::Command& c) {
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
