// StreamClient::Impl's handlers of the server's messages, applied to the shared state.
#include <cmath>

#include "stream/stream_client_impl.hpp"
#include "wire/messages.hpp"

#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "stream/clock_sync.hpp"
#include "stream/frame_decoding.hpp"
#include "stream/handshake.hpp"
#include "stream/protocol_checks.hpp"
#include "stream/volume_assembly.hpp"

namespace palp::view {

using net::kSecond;
using net::ProtocolViolation;

void StreamClient::Impl::on_message(const ConnectionPtr& c, const v1::ServerMessage& m,
                                    std::int64_t now) {
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
    case v1::ServerMessage::kHistory:
      on_history(*c, m.history());
      return;
    case v1::ServerMessage::kTask:
      on_task(m.task());
      return;
    case v1::ServerMessage::kLandmarks:
      on_landmarks(m.landmarks());
      return;
    case v1::ServerMessage::MSG_NOT_SET:
      break;
  }
  // An empty envelope or a message type this client does not know (a newer server): ignored.
}

void StreamClient::Impl::on_welcome(const ConnectionPtr& c, const v1::Welcome& w,
                                    std::int64_t now) {
  if (c->welcomed) throw ProtocolViolation("a second Welcome");
  if (const std::string why = net::welcome_refusal(w); !why.empty()) {
    refuse(c, why);
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

void StreamClient::Impl::on_scene(Connection& c, const v1::SceneInfo& s) {
  std::shared_ptr<SceneDescription> scene = net::decode_scene(s);
  if (c.scene_grid &&
      (scene->dims != c.scene_grid->dims || scene->spacing != c.scene_grid->spacing))
    throw ProtocolViolation("SceneInfo: the grid changed within a connection");
  c.scene_grid = net::SceneGrid{
      scene->dims, scene->spacing,
      scene->structures.empty() ? 0u : std::uint32_t{scene->structures.back().label}};
  scene->server_name = server_name;
  std::lock_guard lock(shared_mutex);
  shared.scene = std::move(scene);
}

void StreamClient::Impl::on_volume(Connection& c, const v1::VolumeChunk& chunk) {
  net::VolumeAssembly::Added added =
      c.assembly.add(chunk, opts.volume_max_dim, c.scene_grid ? &*c.scene_grid : nullptr);
  std::lock_guard lock(shared_mutex);
  shared.link.volume_progress = added.progress;
  if (added.volume) shared.volume = std::move(added.volume);
}

// palpd's force before this client joined: checked, kept until the first frame gives t = 0.
void StreamClient::Impl::on_history(Connection& c, const v1::ForceHistory& h) {
  constexpr int kMaxSamples = 100000;
  const int n = h.server_time_ns_size();
  if (n > kMaxSamples || h.fx_size() != n || h.fy_size() != n || h.fz_size() != n)
    throw ProtocolViolation("ForceHistory: " + std::to_string(n) +
                            " times and forces of other lengths, or over 100000");
  if (c.frames > 0) return;  // late: the chart has begun
  c.joined_history.clear();
  for (int i = 0; i < n; ++i) {
    const Vec3d f{h.fx(i), h.fy(i), h.fz(i)};
    if (!is_finite(f) || (i > 0 && h.server_time_ns(i) <= h.server_time_ns(i - 1)))
      throw ProtocolViolation("ForceHistory: a force not finite or times not increasing");
    c.joined_history.push_back({0.0, f, h.server_time_ns(i)});
  }
}

void StreamClient::Impl::on_task(const v1::TaskStatus& t) {
  TaskInfo info;
  info.running = t.running();
  info.task = t.task().substr(0, 256);
  info.trial = t.trial();
  info.marks = t.marks();
  info.show_landmarks = t.show_landmarks();
  if (t.has_last_mark() && std::isfinite(t.last_mark().distance_mm())) {
    info.last_distance_mm = t.last_mark().distance_mm();
    info.last_in_target = t.last_mark().in_target();
    info.last_where = t.last_mark().where().substr(0, 64);
  }
  std::lock_guard lock(shared_mutex);
  shared.task = std::move(info);
}

// The landmarks to draw: a set over kMaxLandmarks, or with a point not finite, is dropped.
void StreamClient::Impl::on_landmarks(const v1::LandmarkSet& set) {
  if (set.landmarks_size() > kMaxLandmarks) return;
  auto points = std::make_shared<std::vector<LandmarkPoint>>();
  for (const v1::Landmark& l : set.landmarks()) {
    const Vec3d p{l.point().x(), l.point().y(), l.point().z()};
    if (!is_finite(p)) return;
    points->push_back({l.name().substr(0, 64), l.kind().substr(0, 32), p});
  }
  std::lock_guard lock(shared_mutex);
  shared.landmarks = std::move(points);
}

void StreamClient::Impl::on_frame(Connection& c, const v1::HapticFrame& f, std::int64_t now) {
  if (c.assembly.active()) throw ProtocolViolation("a frame before the render volume was complete");
  FrameState frame = net::decode_frame(f);

  if (c.frames == 0) {
    c.first_frame_ns = now;
    c.first_frame_server_ns = f.server_time_ns();
    c.last_history_server_ns = f.server_time_ns() - kSecond;  // the first sample is kept
  }
  ++c.frames;
  c.arrivals.emplace_back(now, f.server_time_ns());
  while (c.arrivals.size() > 1 && c.arrivals.front().first < now - kSecond) c.arrivals.pop_front();
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
  if (c.frames == 1) {  // the session's force before this client joined, t < 0
    history.clear();
    for (ForceSample s : c.joined_history) {
      s.t_s = static_cast<double>(s.server_time_ns - c.first_frame_server_ns) * 1e-9;
      if (s.server_time_ns < f.server_time_ns() && s.t_s >= -opts.force_history_s)
        history.push_back(s);
    }
    c.joined_history.clear();
  }
  if (keep_sample) {
    ForceSample sample;
    sample.t_s = static_cast<double>(f.server_time_ns() - c.first_frame_server_ns) * 1e-9;
    sample.force = frame.force;
    sample.server_time_ns = f.server_time_ns();
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

void StreamClient::Impl::on_stats(Connection& c, const v1::Stats& s) {
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
  l.device_state = palp::wire::from_proto(s.device_state());
  l.device_message = s.device_message();
  if (s.has_registration_home()) {
    const Vec3d home = palp::wire::from_proto(s.registration_home());
    if (is_finite(home)) l.registration_home = home;
  }
  l.recentres = s.recentres();
}

void StreamClient::Impl::on_error(const ConnectionPtr& c, const v1::Error& e) {
  const std::string text = v1::Error::Code_Name(e.code()) + ": " + e.reason();
  if (e.fatal()) {
    if (net::is_refusal(e.code()))
      refuse(c, "refused by the server: " + text);
    else
      drop(c, "the server closed the connection: " + text);
    return;
  }
  std::lock_guard lock(shared_mutex);
  ++shared.link.server_errors;
  shared.link.message = "server: " + text;
}

void StreamClient::Impl::on_pong(Connection& c, const v1::Pong& p, std::int64_t now) {
  c.clock.add_pong(p.client_time_ns(), p.server_time_ns(), now, c.started_ns);
  // LinkStats gets the offset together with the latency computed from it (housekeeping).
}

}  // namespace palp::view
