#include "dds_subscriber.hpp"

#include <chrono>
#include <cstring>
#include <map>
#include <thread>

namespace palp::dds {
namespace {

dds_entity_t reader(dds_entity_t participant, dds_entity_t waitset,
                    const dds_topic_descriptor_t* desc, const std::string& name, QosKind kind,
                    std::int32_t depth) {
  const dds_entity_t topic = make_topic(participant, desc, name);
  const QosPtr qos = make_qos(kind, depth);
  const dds_entity_t r =
      checked(dds_create_reader(participant, topic, qos.get(), nullptr), "reader of " + name);
  const dds_entity_t cond = checked(dds_create_readcondition(r, DDS_ANY_STATE), "read condition");
  checked(dds_waitset_attach(waitset, cond, r), "wait-set");
  return r;
}

// Takes everything `r` holds, calling `f` with each valid sample. Returns how many samples.
template <class T, class F>
std::size_t take_all(dds_entity_t r, F&& f) {
  constexpr std::size_t kBatch = 64;
  std::size_t total = 0;
  while (true) {
    void* samples[kBatch] = {};
    dds_sample_info_t infos[kBatch];
    const dds_return_t n = dds_take(r, samples, infos, kBatch, kBatch);
    if (n <= 0) break;
    for (dds_return_t i = 0; i < n; ++i)
      if (infos[i].valid_data) f(*static_cast<const T*>(samples[i]));
    dds_return_loan(r, samples, n);
    total += static_cast<std::size_t>(n);
    if (static_cast<std::size_t>(n) < kBatch) break;
  }
  return total;
}

}  // namespace

RigSubscriber::RigSubscriber(const SubscriberOptions& options) : options_(options) {
  check_rig(options_.rig);
  participant_ = make_participant(options_.domain);
  const dds_entity_t p = participant_.get();
  waitset_ = checked(dds_create_waitset(p), "wait-set");
  const std::string& rig = options_.rig;
  if (options_.frames && options_.batch)
    batch_ = reader(p, waitset_, &palp_dds_FrameBatch_desc, topic_name(rig, kFrameBatch),
                    QosKind::Stream, options_.frame_depth);
  else if (options_.frames)
    frames_ = reader(p, waitset_, &palp_dds_HapticFrame_desc,
                     topic_name(rig, options_.contacts ? kFramesContacts : kFrames),
                     QosKind::Stream, options_.frame_depth);
  if (options_.ros) {
    pose_ = reader(p, waitset_, &geometry_msgs_msg_dds__PoseStamped__desc,
                   topic_name(rig, kToolPose), QosKind::Stream, options_.frame_depth);
    wrench_ = reader(p, waitset_, &geometry_msgs_msg_dds__WrenchStamped__desc,
                     topic_name(rig, kWrench), QosKind::Stream, options_.frame_depth);
  }
  if (options_.scene)
    scene_ =
        reader(p, waitset_, &palp_dds_Encoded_desc, topic_name(rig, kScene), QosKind::Latched, 1);
  if (options_.stats)
    stats_ =
        reader(p, waitset_, &palp_dds_Encoded_desc, topic_name(rig, kStats), QosKind::Latched, 1);
  if (options_.volume)
    volume_ =
        reader(p, waitset_, &palp_dds_Encoded_desc, topic_name(rig, kVolume), QosKind::Latched, 1);
}

bool RigSubscriber::wait(double timeout_s) {
  const dds_return_t n =
      dds_waitset_wait(waitset_, nullptr, 0, static_cast<dds_duration_t>(timeout_s * 1e9));
  return n > 0;
}

std::size_t RigSubscriber::take(const Handlers& h) {
  const std::int64_t now = realtime_ns();
  std::size_t n = 0;
  // The scene (and the volume) before the frames that need them.
  const std::pair<dds_entity_t, const char*> encoded[] = {
      {scene_, kScene}, {stats_, kStats}, {volume_, kVolume}};
  for (const auto& [r, leaf] : encoded)
    if (r)
      n += take_all<palp_dds_Encoded>(r, [&, leaf = leaf](const palp_dds_Encoded& s) {
        // Its rig is an unbounded string on the wire: checked (and bounded) before use.
        if (!same_rig(s.rig, options_.rig))
          ++foreign_;
        else if (h.encoded)
          h.encoded(leaf, s);
      });
  if (frames_)
    n += take_all<palp_dds_HapticFrame>(frames_, [&](const palp_dds_HapticFrame& s) {
      if (h.frame) h.frame(s, now);
    });
  if (batch_)
    n += take_all<palp_dds_FrameBatch>(batch_, [&](const palp_dds_FrameBatch& b) {
      ++batches_;
      if (!h.frame) return;
      palp_dds_HapticFrame f{};
      std::memcpy(f.rig, b.rig, sizeof f.rig);
      for (std::uint32_t i = 0; i < b.frames._length; ++i) {
        set_from_batch_frame(b.frames._buffer[i], f);
        h.frame(f, now);
      }
    });
  if (pose_)
    n += take_all<geometry_msgs_msg_dds__PoseStamped_>(
        pose_, [&](const geometry_msgs_msg_dds__PoseStamped_& s) {
          if (h.pose) h.pose(s, now);
        });
  if (wrench_)
    n += take_all<geometry_msgs_msg_dds__WrenchStamped_>(
        wrench_, [&](const geometry_msgs_msg_dds__WrenchStamped_& s) {
          if (h.wrench) h.wrench(s, now);
        });
  return n;
}

std::uint32_t RigSubscriber::frame_writers() const {
  const dds_entity_t r = batch_ ? batch_ : frames_;
  if (!r) return 0;
  dds_subscription_matched_status_t st{};
  if (dds_get_subscription_matched_status(r, &st) < 0) return 0;
  return st.current_count;
}

std::vector<RigSeen> list_rigs(std::uint32_t domain, double listen_s) {
  Entity participant = make_participant(domain);
  const dds_entity_t p = participant.get();
  const dds_entity_t topic = make_topic(p, &palp_dds_RigInfo_desc, kRigsTopic);
  const QosPtr qos = make_qos(QosKind::Latched, 1);
  const dds_entity_t r =
      checked(dds_create_reader(p, topic, qos.get(), nullptr), "reader of the rigs");
  std::this_thread::sleep_for(std::chrono::duration<double>(listen_s));
  std::map<std::string, RigSeen> seen;
  constexpr std::size_t kBatch = 64;
  void* samples[kBatch] = {};
  dds_sample_info_t infos[kBatch];
  const dds_return_t n = dds_read(r, samples, infos, kBatch, kBatch);
  for (dds_return_t i = 0; i < n; ++i) {
    const auto& s = *static_cast<const palp_dds_RigInfo*>(samples[i]);
    // The key (valid in an invalid sample too) is an unbounded string on the wire: a rig name
    // that is not one is ignored, the other strings are cut to kMaxRigText bytes.
    if (!valid_rig(s.rig)) continue;
    RigSeen& rig = seen[s.rig];
    rig.rig = s.rig;
    rig.alive = infos[i].instance_state == DDS_IST_ALIVE;
    if (!infos[i].valid_data) continue;
    rig.host = text(s.host, kMaxRigText), rig.scene = text(s.scene, kMaxRigText);
    rig.tool = text(s.tool, kMaxRigText), rig.device = text(s.device, kMaxRigText);
    rig.pid = s.pid, rig.rate_hz = s.rate_hz;
    rig.control = s.control, rig.started_ns = from_time(s.started);
  }
  if (n > 0) dds_return_loan(r, samples, n);
  std::vector<RigSeen> out;
  for (auto& [name, rig] : seen) out.push_back(std::move(rig));
  return out;
}

}  // namespace palp::dds
