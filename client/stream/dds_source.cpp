// palpview over DDS (palpd --dds; docs/dds.md): StreamClient's thread, with opts.dds, subscribes
// to one rig (proto/dds/dds_subscriber.hpp) instead of connecting over palp.v1, and hands what
// arrives to the same handlers palp.v1 messages go through (server_messages.cpp): SceneInfo,
// the volume's chunks (in index order, once all are there), Stats, and each frame converted to a
// palp.v1 HapticFrame. The render side sees the same LatestState either way. Observer only.
#include <algorithm>

#include "dds_subscriber.hpp"
#include "stream/dds_volume_chunks.hpp"
#include "stream/stream_client_impl.hpp"

namespace palp::view {

using net::kSecond;
using net::now_ns;

namespace {

void set(v1::Vec3* out, const palp_dds_Vec3& v) {
  out->set_x(v.x);
  out->set_y(v.y);
  out->set_z(v.z);
}

void to_proto(const palp_dds_HapticFrame& f, v1::HapticFrame* out) {
  out->set_seq(f.seq);
  out->set_server_time_ns(f.server_time_ns);
  set(out->mutable_device_pose()->mutable_position(), f.position);
  v1::Quat* q = out->mutable_device_pose()->mutable_orientation();
  q->set_w(f.orientation.w), q->set_x(f.orientation.x), q->set_y(f.orientation.y);
  q->set_z(f.orientation.z);
  set(out->mutable_force(), f.force);
  set(out->mutable_torque(), f.torque);
  set(out->mutable_displacement(), f.u);
  out->set_n_contact(f.n_contact);
  out->set_tick_status(f.tick_status);
  out->set_safety_status(f.safety_status);
  out->set_fault(f.fault);
  out->set_contact_points(f.contact_points);
  out->set_device_state(static_cast<v1::DeviceState>(f.device_state));
  for (std::uint32_t i = 0; i < f.contacts._length; ++i) {
    const palp_dds_Contact& c = f.contacts._buffer[i];
    v1::Contact* pc = out->add_contacts();
    set(pc->mutable_position(), c.x);
    set(pc->mutable_surface(), c.s);
    set(pc->mutable_proxy(), c.p);
    set(pc->mutable_force(), c.f);
    pc->set_in_contact(c.in_contact);
  }
}

}  // namespace

void StreamClient::Impl::dds_refused(const std::string& why) {
  std::lock_guard lock(shared_mutex);
  shared.link.state = LinkState::Refused;
  shared.link.message = why;
}

StreamClient::Impl::ConnectionPtr StreamClient::Impl::start_dds_link(const std::string& where) {
  auto c = std::make_shared<Connection>(io);
  c->welcomed = true;
  c->started_ns = 0;  // frames' stamps give the clock offset (ClockSync accepts any time)
  std::lock_guard lock(shared_mutex);
  ++shared.link.connections;
  shared.connection = shared.link.connections;
  shared.link.state = LinkState::Loading;
  shared.link.message = where + ": waiting for palpd";
  shared.link.volume_progress = opts.volume_max_dim > 0 ? 0.0 : 1.0;
  return c;
}

void StreamClient::Impl::dds_housekeeping(Connection& c, const std::string& where) {
  // What housekeeping() does for palp.v1: rates, latency, stalls.
  const std::int64_t now = now_ns();
  while (!c.arrivals.empty() && c.arrivals.front().first < now - kSecond) c.arrivals.pop_front();
  double fps = 0;
  if (c.frames > 0)
    fps = static_cast<double>(c.arrivals.size()) /
          std::clamp(static_cast<double>(now - c.first_frame_ns) * 1e-9, 0.25, 1.0);
  const double median = net::median_latency_ms(c.arrivals, c.clock, latencies);
  std::lock_guard lock(shared_mutex);
  LinkStats& l = shared.link;
  l.frames_per_s = fps;
  l.latency_ms = median;
  if (l.state == LinkState::Live && c.frames > 0 &&
      static_cast<double>(now - last_frame_ns) > opts.stall_s * 1e9) {
    l.state = LinkState::Stalled;
    l.message = where + ": no frame for a while";
  }
}

void StreamClient::Impl::run_dds() {
  const std::string where =
      "DDS domain " + std::to_string(opts.dds_domain) + ", rig " + opts.dds_rig;
  std::unique_ptr<palp::dds::RigSubscriber> sub;
  try {
    palp::dds::SubscriberOptions so;
    so.domain = opts.dds_domain;
    so.rig = opts.dds_rig;
    so.contacts = opts.want_contacts;
    so.volume = opts.volume_max_dim > 0;
    sub = std::make_unique<palp::dds::RigSubscriber>(so);
  } catch (const std::exception& e) {
    dds_refused(e.what());
    return;
  }
  const ConnectionPtr c = start_dds_link(where);
  DdsVolumeChunks chunks;  // until all are there and the scene has come
  std::uint64_t scene_version = 0;
  bool volume_fed = opts.volume_max_dim == 0;
  std::int64_t last_offset_ns = 0;
  palp::dds::Handlers h;
  h.encoded = [&](const char* leaf, const palp_dds_Encoded& e) {
    const std::string which = leaf;
    const auto* data = e.payload._buffer;
    const int size = static_cast<int>(e.payload._length);
    try {
      if (which == palp::dds::kScene) {
        v1::SceneInfo s;
        if (!s.ParseFromArray(data, size) || e.version == scene_version) return;
        scene_version = e.version;
        on_scene(*c, s);
      } else if (which == palp::dds::kStats) {
        v1::Stats s;
        if (s.ParseFromArray(data, size)) on_stats(*c, s);
      } else if (which == palp::dds::kVolume && !volume_fed) {
        // kept even before the scene: each latched topic is delivered on its own
        v1::VolumeChunk chunk;
        if (chunk.ParseFromArray(data, size)) chunks.add(e.index, e.count, std::move(chunk));
      }
      // the volume once all its chunks and the scene are there (in either order)
      if (!volume_fed && c->scene_grid)
        volume_fed = chunks.hand_over([&](const v1::VolumeChunk& ch) { on_volume(*c, ch); });
    } catch (const std::exception& ex) {
      std::lock_guard lock(shared_mutex);
      shared.link.message = where + ": " + ex.what();
    }
  };
  v1::HapticFrame frame;
  h.frame = [&](const palp_dds_HapticFrame& f, std::int64_t) {
    if (!volume_fed || c->assembly.active() || !c->scene_grid) return;
    const std::int64_t now = now_ns();
    if (now - last_offset_ns > kSecond) {  // server clock - this clock, from the stamp
      last_offset_ns = now;
      const std::int64_t local = now - (palp::dds::realtime_ns() - palp::dds::from_time(f.stamp));
      c->clock.add_pong(local, f.server_time_ns, local, 0);
    }
    frame.Clear();
    to_proto(f, &frame);
    try {
      on_frame(*c, frame, now);
    } catch (const std::exception& ex) {
      std::lock_guard lock(shared_mutex);
      shared.link.message = where + ": " + ex.what();
    }
  };
  while (!dds_stop.load()) {
    if (sub->wait(0.02)) sub->take(h);
    dds_housekeeping(*c, where);
  }
}

}  // namespace palp::view
