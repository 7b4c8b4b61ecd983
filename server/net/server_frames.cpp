// The palpd network server's unasked messages and housekeeping (server_impl.hpp): frames drained
// from the loop's ring, the scene, render volume and training task sent to the clients, the
// timeouts checked every 50 ms and Stats about once a second.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <vector>

#include "net/protocol.hpp"
#include "net/scene_messages.hpp"
#include "net/server_impl.hpp"
#include "net/task_messages.hpp"

namespace palp::net {
namespace {

std::int64_t seconds_to_ns(double s) {
  return static_cast<std::int64_t>(s * 1e9);
}

}  // namespace

// The training task: TaskStatus to each client as its role may see it (task_messages.hpp).
TaskSession* Server::Impl::task() {
  return control_ ? control_->task() : nullptr;
}

bool Server::Impl::queue_task(Session& s, const TaskSession& t) {
  for (Bytes& b : task_frames(t, s.role == v1::CONTROLLER, s.landmarks_sent))
    if (!queue(s, std::move(b))) return false;
  return true;
}

void Server::Impl::send_task_to_all() {
  if (TaskSession* t = task()) {
    task_revision_ = t->revision();
    for (const SessionPtr& s : sessions_)
      if (s->welcomed && !s->closing && !s->closed && queue_task(*s, *t)) pump(s);
  }
}

// One SceneInfo, shared by every welcomed client; it replaces one still queued for a client.
void Server::Impl::send_scene_to_all() {
  scene_dirty_ = false;
  const Bytes scene = scene_frame();
  for (const SessionPtr& s : sessions_)
    if (s->welcomed && !s->closing && !s->closed && queue_scene(*s, scene)) pump(s);
}

// ------------------------------------------------------------------ scene and volume
Bytes Server::Impl::scene_frame() {
  v1::ServerMessage m;
  fill_scene_info(scene_, loop_, m.mutable_scene());
  return frame_of(m);
}

void Server::Impl::plan_volume(Session& s, const VolumeRequest& r) {
  if (!scene_.fields || (r.step == 0 && r.max_dim == 0)) return;
  s.volume = volume_cache_.plan(r);
  if (s.volume.chunks > 0) s.volume_frames = volume_cache_.get(s.volume);
}

Bytes Server::Impl::next_volume_chunk(
    Session& s) {  // null: not encoded yet (volume_cache_ wakes us)
  Bytes b = s.volume_frames->frame(s.volume_chunk);
  if (b && ++s.volume_chunk == s.volume.chunks) became_ready(s);
  if (s.ready) s.volume_frames.reset();
  return b;
}

// ------------------------------------------------------------------ frames from the loop
// Run by the frame pump (frame_pump.hpp) whenever the loop woke it, and on its backstop.
void Server::Impl::frames_published() {
  if (scene_dirty_) send_scene_to_all();
  drain();
  if (task() && task()->revision() != task_revision_) send_task_to_all();  // a button's mark
  want_frames();
  graveyard_.free_some(kFreePerPoll);
}

// Tells the loop the earliest snapshot time a client or a tap takes next (before the pump
// arms: frame_pump.hpp), so it wakes this thread for that tick and not for every one (issue 41).
void Server::Impl::want_frames() {
  std::int64_t due = rt::WakeSignal::kNobody;
  for (const SessionPtr& s : sessions_)
    if (s->ready && !s->closing && !s->closed) due = std::min(due, s->frames.due());
  for (const Tap& tap : taps_) due = std::min(due, tap.frames.due());
  loop_.net_signal().want_from(due);
}

// Frames flow to `s` from the next snapshot on: the loop is told at once.
void Server::Impl::became_ready(Session& s) {
  s.ready = true;
  loop_.net_signal().want_from(std::min(loop_.net_signal().wanted_from(), s.frames.due()));
}

void Server::Impl::drain() {
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
void Server::Impl::schedule_house() {
  house_timer_.expires_after(std::chrono::milliseconds(50));
  house_timer_.async_wait([this](const asio::error_code& ec) {
    if (ec) return;
    housekeeping();
    schedule_house();
  });
}

void Server::Impl::housekeeping() {
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
    if (config_.idle_timeout_s > 0 && now - s->last_rx_ns > seconds_to_ns(config_.idle_timeout_s)) {
      timeouts_.fetch_add(1);
      fatal(s, v1::Error::TIMEOUT, "nothing received for too long (send Ping)");
      continue;
    }
  }
  std::erase_if(sessions_, [](const SessionPtr& s) { return s->closed; });
  client_count_.store(sessions_.size());
  if (now - last_stats_ns_ >= seconds_to_ns(config_.stats_interval_s)) send_stats(now);
}

void Server::Impl::send_stats(std::int64_t now) {
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

}  // namespace palp::net
