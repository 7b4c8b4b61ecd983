#include "interop/dds_publisher.hpp"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <thread>
#include <vector>

#include "base/errors.hpp"
#include "dds_common.hpp"
#include "interop/dds_batch.hpp"
#include "loop/wake.hpp"
#include "net/scene_messages.hpp"
#include "net/token_guard.hpp"
#include "ros2_types.h"
#include "rt/wake_signal.hpp"

namespace palp::interop {

namespace {

constexpr char kFrameId[] = "palp_scene";  // ROS 2 header frame_id: palp's scene frame

palp_dds_Vec3 vec(const Vec3d& v) {
  return {v.x, v.y, v.z};
}

std::vector<std::uint8_t> bytes_of(const google::protobuf::MessageLite& m) {
  std::vector<std::uint8_t> out(m.ByteSizeLong());
  m.SerializeToArray(out.data(), static_cast<int>(out.size()));
  return out;
}

}  // namespace

class DdsPublisher::Impl {
 public:
  Impl(DdsConfig config, const net::SceneDescription& scene, rt::HapticLoop& loop,
       net::ControlTarget* control, std::string host, std::string tool)
      : config_(std::move(config)),
        scene_(scene),
        loop_(loop),
        control_(control),
        ring_(config_.queue, loop.net_ring().contact_capacity()),
        indices_(ring_.capacity()),
        contacts_(loop.net_ring().contact_capacity()) {
    using namespace palp::dds;
    check_rig(config_.rig);
    participant_ = make_participant(config_.domain);
    const dds_entity_t p = participant_.get();
    const auto writer = [&](const dds_topic_descriptor_t* desc, const std::string& name,
                            QosKind kind, std::int32_t depth) {
      const dds_entity_t topic = make_topic(p, desc, name);
      const QosPtr qos = make_qos(kind, depth);
      return checked(dds_create_writer(p, topic, qos.get(), nullptr), "writer of " + name);
    };
    const std::string& rig = config_.rig;
    frames_ = writer(&palp_dds_HapticFrame_desc, topic_name(rig, kFrames), QosKind::Stream,
                     config_.depth);
    full_ = writer(&palp_dds_HapticFrame_desc, topic_name(rig, kFramesContacts), QosKind::Stream,
                   config_.depth);
    if (config_.batch_ms > 0) {
      batch_ = writer(&palp_dds_FrameBatch_desc, topic_name(rig, kFrameBatch), QosKind::Stream,
                      config_.depth);
      const double hz = config_.rate_hz > 0 ? config_.rate_hz : loop.config().rate_hz;
      batcher_ = std::make_unique<FrameBatcher>(
          rig, static_cast<std::int64_t>(config_.batch_ms * 1e6 + 0.5),
          hz > 0 ? static_cast<std::int64_t>(1e9 / hz + 0.5) : 0);
    }
    pose_ = writer(&geometry_msgs_msg_dds__PoseStamped__desc, topic_name(rig, kToolPose),
                   QosKind::Stream, config_.depth);
    wrench_ = writer(&geometry_msgs_msg_dds__WrenchStamped__desc, topic_name(rig, kWrench),
                     QosKind::Stream, config_.depth);
    scene_w_ = writer(&palp_dds_Encoded_desc, topic_name(rig, kScene), QosKind::Latched, 1);
    stats_w_ = writer(&palp_dds_Encoded_desc, topic_name(rig, kStats), QosKind::Latched, 1);
    rigs_w_ = writer(&palp_dds_RigInfo_desc, kRigsTopic, QosKind::Latched, 1);
    if (config_.volume_max_dim > 0)
      volume_w_ = writer(&palp_dds_Encoded_desc, topic_name(rig, kVolume), QosKind::Latched, 1);
    if (config_.control) {
      const dds_entity_t topic =
          make_topic(p, &palp_dds_DevicePose_desc, topic_name(rig, kDevicePose));
      const QosPtr qos = make_qos(QosKind::Command, 1);
      control_r_ = checked(dds_create_reader(p, topic, qos.get(), nullptr), "device_pose reader");
    }
    host_ = std::move(host), tool_ = std::move(tool);
    // The render volume, prepared now: the chunks palp.v1 would send a client that asks for
    // max_dim voxels an axis, with HU, bone, the structures' labels and zlib.
    if (volume_w_) {
      net::VolumeRequest request;
      request.max_dim = config_.volume_max_dim;
      request.hu = true, request.bone = true, request.deflate = true, request.labels = true;
      const net::VolumePlan plan = net::plan_volume(scene_, request, 1 << 20);
      std::uint32_t k = 0;
      for (std::uint32_t i = 0; i < plan.chunks; ++i) {
        v1::VolumeChunk chunk;
        k += net::fill_volume_chunk(scene_, plan, k, i, &chunk);
        volume_.push_back(bytes_of(chunk));
      }
    }
    started_ns_ = realtime_ns();
  }

  ~Impl() { stop(); }

  void start() {
    write_rig(true);
    write_scene(true);
    for (std::size_t i = 0; i < volume_.size(); ++i)
      write_encoded(volume_w_, static_cast<std::uint32_t>(i),
                    static_cast<std::uint32_t>(volume_.size()), 1, volume_[i]);
    volume_chunks_ = volume_.size();
    volume_.clear();
    volume_.shrink_to_fit();  // the writer keeps them
    signal_.attach(true);
    running_ = true;
    thread_ = std::thread([this] { run(); });
  }

  void stop() {
    if (!running_.exchange(false)) return;
    signal_.notify();
    const std::uint64_t one = 1;
    (void)!::write(signal_.fd(), &one, sizeof one);
    if (thread_.joinable()) thread_.join();
    signal_.detach();
    write_rig(false);
    if (config_.report) {
      const DdsCounters c = counters();
      std::printf(
          "palpd: DDS rig %s: %llu frames published, %llu batches, %llu dropped before "
          "publishing, %llu write errors, %u subscribers at the end\n",
          config_.rig.c_str(), static_cast<unsigned long long>(c.published),
          static_cast<unsigned long long>(c.batches), static_cast<unsigned long long>(c.dropped),
          static_cast<unsigned long long>(c.write_errors), c.subscribers);
      std::fflush(stdout);
    }
  }

  void offer(const rt::Snapshot& s) noexcept {
    const std::int64_t t = s.tick.t_ns;
    if (interval_ns_ > 0) {
      if (t < next_ns_) return;
      next_ns_ = std::max(next_ns_ + interval_ns_, t);
      if (next_ns_ <= t) next_ns_ = t + interval_ns_;
    }
    // Every kept snapshot gets the next frame index, published or not: a snapshot dropped here
    // shows as a gap to subscribers, like one lost on the network. Publishing every tick, ticks
    // the loop's ring to the io thread dropped (a jump in seq) take indices too.
    std::uint64_t skipped = 0;
    if (interval_ns_ == 0 && seen_ && s.tick.seq > last_seq_ + 1)
      skipped = s.tick.seq - last_seq_ - 1;
    seen_ = true, last_seq_ = s.tick.seq;
    const std::uint64_t index =
        offered_.fetch_add(1 + skipped, std::memory_order_relaxed) + skipped;
    rt::Snapshot* slot = ring_.claim();
    if (!slot) return;  // counted by the ring
    indices_[claimed_++ & (indices_.size() - 1)] = index;
    slot->tick = s.tick;
    slot->device_state = s.device_state;
    slot->contact_points = s.contact_points;
    const std::size_t n = std::min<std::size_t>(s.contact_count, slot->contacts.size());
    slot->contact_count = static_cast<std::uint32_t>(n);
    std::copy_n(s.contacts.begin(), n, slot->contacts.begin());
    ring_.commit();
    signal_.notify();
  }

  DdsCounters counters() const {
    DdsCounters c;
    c.offered = offered_.load(std::memory_order_relaxed);
    c.dropped = ring_.dropped();
    c.published = published_.load(std::memory_order_relaxed);
    c.batches = batches_.load(std::memory_order_relaxed);
    c.write_errors = write_errors_.load(std::memory_order_relaxed);
    c.scene_versions = scene_version_.load(std::memory_order_relaxed);
    c.volume_chunks = volume_chunks_;
    c.poses_accepted = poses_accepted_.load(std::memory_order_relaxed);
    c.poses_refused = poses_refused_.load(std::memory_order_relaxed);
    dds_publication_matched_status_t st{};
    if (dds_get_publication_matched_status(frames_, &st) >= 0) c.subscribers = st.current_count;
    if (dds_get_publication_matched_status(full_, &st) >= 0) c.subscribers += st.current_count;
    if (batch_ && dds_get_publication_matched_status(batch_, &st) >= 0)
      c.subscribers += st.current_count;
    return c;
  }

  const DdsConfig& config() const { return config_; }

 private:
  void run() {
    std::int64_t next_stats = rt::monotonic_ns();
    while (running_.load(std::memory_order_relaxed)) {
      drain();
      const std::int64_t now = rt::monotonic_ns();
      if (now >= next_stats) {
        write_stats(now);
        write_scene(false);
        next_stats = now + static_cast<std::int64_t>(config_.stats_interval_s * 1e9);
      }
      if (control_r_) take_poses();
      signal_.arm();
      if (ring_.front()) continue;
      std::int64_t wait_ms = (next_stats - rt::monotonic_ns()) / 1000000 + 1;
      if (control_r_) wait_ms = std::min<std::int64_t>(wait_ms, 5);
      if (batcher_ && batcher_->size() > 0)
        wait_ms = std::min<std::int64_t>(wait_ms, static_cast<std::int64_t>(config_.batch_ms) + 1);
      pollfd pfd{signal_.fd(), POLLIN, 0};
      ::poll(&pfd, 1, static_cast<int>(std::clamp<std::int64_t>(wait_ms, 0, 1000)));
      signal_.consume();
    }
    drain();
    if (batcher_ && batcher_->size() > 0) write_batch();  // the last, partial batch
  }

  void drain() {
    using namespace palp::dds;
    // The tick's deadline on CLOCK_REALTIME: the offset between the two clocks, once a batch.
    const std::int64_t offset = realtime_ns() - rt::monotonic_ns();
    // A topic nobody reads is not written (serialising a frame costs even without readers).
    const bool want_frames = matched(frames_), want_full = matched(full_);
    const bool want_pose = matched(pose_), want_wrench = matched(wrench_);
    const bool want_batch = batch_ && matched(batch_);
    if (batcher_ && !want_batch) batcher_->drop();  // its readers left
    while (const rt::Snapshot* s = ring_.front()) {
      const rt::TickRecord& t = s->tick;
      const auto stamp = to_time(t.t_ns + offset);
      palp_dds_HapticFrame f{};
      std::snprintf(f.rig, sizeof f.rig, "%s", config_.rig.c_str());
      f.frame_index = indices_[popped_++ & (indices_.size() - 1)];
      f.seq = t.seq;
      f.server_time_ns = t.t_ns;
      f.stamp = stamp;
      f.position = vec(t.pose.position);
      f.orientation = {t.pose.orientation.w, t.pose.orientation.x, t.pose.orientation.y,
                       t.pose.orientation.z};
      f.force = vec(t.force), f.torque = vec(t.torque), f.u = vec(t.u);
      f.n_contact = static_cast<std::uint32_t>(t.n_contact);
      f.contact_points = s->contact_points;
      f.tick_status = t.tick_status, f.safety_status = t.safety_status, f.fault = t.fault;
      f.device_state = static_cast<std::uint8_t>(s->device_state);
      if (want_frames) count(dds_write(frames_, &f));
      if (want_full) {
        for (std::uint32_t i = 0; i < s->contact_count; ++i) {
          const rt::ContactSnapshot& c = s->contacts[i];
          contacts_[i] = {vec(c.x), vec(c.s), vec(c.p), vec(c.f), c.in_contact != 0};
        }
        f.contacts._length = f.contacts._maximum = s->contact_count;
        f.contacts._buffer = contacts_.data();
        f.contacts._release = false;
        count(dds_write(full_, &f));
      }
      published_.fetch_add(1, std::memory_order_relaxed);
      if (want_batch) {
        const palp_dds_BatchFrame b = batch_frame_of(f);
        if (batcher_->due_before(b.server_time_ns)) write_batch();
        batcher_->add(b);
        if (batcher_->complete()) write_batch();
      }

      // ROS 2: metres, newtons, newton-metres.
      char frame_id[sizeof kFrameId];
      std::memcpy(frame_id, kFrameId, sizeof kFrameId);
      geometry_msgs_msg_dds__PoseStamped_ pose{};
      pose.header.stamp = stamp;
      pose.header.frame_id = frame_id;
      pose.pose.position = {t.pose.position.x * 1e-3, t.pose.position.y * 1e-3,
                            t.pose.position.z * 1e-3};
      pose.pose.orientation = {t.pose.orientation.x, t.pose.orientation.y, t.pose.orientation.z,
                               t.pose.orientation.w};
      if (want_pose) count(dds_write(pose_, &pose));
      geometry_msgs_msg_dds__WrenchStamped_ wrench{};
      wrench.header = pose.header;
      wrench.wrench.force = {t.force.x, t.force.y, t.force.z};
      wrench.wrench.torque = {t.torque.x * 1e-3, t.torque.y * 1e-3, t.torque.z * 1e-3};
      if (want_wrench) count(dds_write(wrench_, &wrench));
      ring_.pop();
    }
    if (want_batch && batcher_->stale(rt::monotonic_ns())) write_batch();  // no frame coming
  }

  void write_batch() {
    count(dds_write(batch_, &batcher_->sample()));
    batcher_->clear();
    batches_.fetch_add(1, std::memory_order_relaxed);
  }

  static bool matched(dds_entity_t writer) {
    dds_publication_matched_status_t st{};
    return dds_get_publication_matched_status(writer, &st) >= 0 && st.current_count > 0;
  }

  void count(dds_return_t rc) {
    if (rc != DDS_RETCODE_OK) write_errors_.fetch_add(1, std::memory_order_relaxed);
  }

  // The rig as the keyed types carry it (an unbounded string in the IDL): config_.rig, checked
  // by check_rig in the constructor (at most kMaxRigBytes) and not changed since.
  char* rig_key() { return config_.rig.data(); }

  void write_encoded(dds_entity_t w, std::uint32_t index, std::uint32_t n, std::uint64_t version,
                     std::vector<std::uint8_t>& bytes) {
    palp_dds_Encoded e{};
    e.rig = rig_key();
    e.index = index, e.count = n, e.version = version;
    e.stamp = palp::dds::to_time(palp::dds::realtime_ns());
    e.payload._length = e.payload._maximum = static_cast<std::uint32_t>(bytes.size());
    e.payload._buffer = bytes.data();
    e.payload._release = false;
    count(dds_write(w, &e));
  }

  // SceneInfo when it differs from the last one written (a new tool, new parameters).
  void write_scene(bool first) {
    v1::SceneInfo info;
    net::fill_scene_info(scene_, loop_, &info);
    std::string text;
    info.SerializeToString(&text);
    if (!first && text == scene_bytes_) return;
    scene_bytes_ = text;
    std::vector<std::uint8_t> bytes(text.begin(), text.end());
    write_encoded(scene_w_, 0, 1, scene_version_.fetch_add(1) + 1, bytes);
  }

  void write_stats(std::int64_t now) {
    const rt::LoopStats ls = loop_.stats();
    const double dt = static_cast<double>(now - last_stats_ns_) * 1e-9;
    const double rate =
        last_stats_ns_ > 0 && dt > 0 ? static_cast<double>(ls.ticks - last_ticks_) / dt : 0.0;
    last_stats_ns_ = now, last_ticks_ = ls.ticks;
    const DdsCounters c = counters();
    v1::Stats st;
    net::fill_stats(ls, loop_, scene_, nullptr, rate, now, c.subscribers, &st);
    st.set_client_frames_sent(c.published);
    st.set_client_frames_dropped(c.dropped);
    std::vector<std::uint8_t> bytes = bytes_of(st);
    write_encoded(stats_w_, 0, 1, ++stats_version_, bytes);
  }

  void write_rig(bool alive) {
    palp_dds_RigInfo r{};
    r.rig = rig_key();
    if (!alive) {
      dds_dispose(rigs_w_, &r);
      return;
    }
    std::string scene = scene_.source, device = scene_.device;
    r.host = host_.data(), r.scene = scene.data(), r.tool = tool_.data(), r.device = device.data();
    r.pid = static_cast<std::uint32_t>(::getpid());
    r.rate_hz = loop_.config().rate_hz;
    r.control = config_.control;
    r.started = palp::dds::to_time(started_ns_);
    count(dds_write(rigs_w_, &r));
  }

  void take_poses() {
    constexpr std::size_t kBatch = 16;
    void* samples[kBatch] = {};
    dds_sample_info_t infos[kBatch];
    const dds_return_t n = dds_take(control_r_, samples, infos, kBatch, kBatch);
    if (n <= 0) return;
    const std::int64_t now = rt::monotonic_ns();
    for (dds_return_t i = 0; i < n; ++i) {
      if (!infos[i].valid_data) continue;
      const auto& s = *static_cast<const palp_dds_DevicePose*>(samples[i]);
      const bool ok = s.rig == config_.rig && net::same_token(s.token, config_.token);
      Pose pose;
      pose.position = {s.position.x, s.position.y, s.position.z};
      pose.orientation = {s.orientation.w, s.orientation.x, s.orientation.y, s.orientation.z};
      const bool finite = std::isfinite(pose.position.x) && std::isfinite(pose.position.y) &&
                          std::isfinite(pose.position.z) && std::isfinite(pose.orientation.w) &&
                          std::isfinite(pose.orientation.x) && std::isfinite(pose.orientation.y) &&
                          std::isfinite(pose.orientation.z);
      if (ok && finite && control_ && control_->set_device_pose(pose, now)) {
        poses_accepted_.fetch_add(1, std::memory_order_relaxed);
      } else {
        poses_refused_.fetch_add(1, std::memory_order_relaxed);
        if (now - last_refusal_log_ns_ > 1000000000) {
          last_refusal_log_ns_ = now;
          std::fprintf(stderr, "palpd: DDS device pose refused (%s)\n",
                       !ok       ? "wrong rig or token"
                       : !finite ? "not finite"
                                 : "the device is not remote");
        }
      }
    }
    dds_return_loan(control_r_, samples, n);
  }

  DdsConfig config_;
  const net::SceneDescription scene_;
  rt::HapticLoop& loop_;
  net::ControlTarget* control_;
  rt::SnapshotRing ring_;
  rt::WakeSignal signal_;
  std::vector<std::uint64_t> indices_;  // frame index of each ring slot (same size, same order)
  std::vector<palp_dds_Contact> contacts_;
  std::unique_ptr<FrameBatcher> batcher_;  // with batch_ms
  palp::dds::Entity participant_;
  dds_entity_t frames_ = 0, full_ = 0, batch_ = 0, pose_ = 0, wrench_ = 0, scene_w_ = 0,
               stats_w_ = 0, rigs_w_ = 0, volume_w_ = 0, control_r_ = 0;
  std::string host_, tool_, scene_bytes_;
  std::vector<std::vector<std::uint8_t>> volume_;
  std::int64_t started_ns_ = 0;
  std::thread thread_;
  std::atomic<bool> running_{false};
  // io thread (offer)
  std::int64_t interval_ns_ = config_.rate_hz > 0 ? static_cast<std::int64_t>(1e9 / config_.rate_hz)
                                                  : 0;
  std::int64_t next_ns_ = 0;
  std::uint64_t claimed_ = 0, last_seq_ = 0;
  bool seen_ = false;
  std::atomic<std::uint64_t> offered_{0};
  // DDS thread
  std::uint64_t popped_ = 0, stats_version_ = 0, last_ticks_ = 0;
  std::int64_t last_stats_ns_ = 0, last_refusal_log_ns_ = 0;
  std::atomic<std::uint64_t> published_{0}, batches_{0}, write_errors_{0}, scene_version_{0};
  std::atomic<std::uint64_t> poses_accepted_{0}, poses_refused_{0};
  std::size_t volume_chunks_ = 0;
};

DdsPublisher::DdsPublisher(DdsConfig config, const net::SceneDescription& scene,
                           rt::HapticLoop& loop, net::ControlTarget* control, std::string host,
                           std::string tool)
    : impl_(std::make_unique<Impl>(std::move(config), scene, loop, control, std::move(host),
                                   std::move(tool))) {}
DdsPublisher::~DdsPublisher() = default;
const DdsConfig& DdsPublisher::config() const {
  return impl_->config();
}
void DdsPublisher::start() {
  impl_->start();
}
void DdsPublisher::stop() {
  impl_->stop();
}
void DdsPublisher::offer(const rt::Snapshot& snapshot) noexcept {
  impl_->offer(snapshot);
}
DdsCounters DdsPublisher::counters() const {
  return impl_->counters();
}

}  // namespace palp::interop
