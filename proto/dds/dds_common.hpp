// What palpd's DDS publisher and its subscribers (palp probe --dds, palpview --dds) share: topic
// names, rig names, the QoS of each kind of topic, times, and a handle that deletes its entity.
// Types come from palp_types.idl / ros2_types.idl (compiled by idlc at build time, type
// information kept). Participants use Cyclone's default configuration: CYCLONEDDS_URI is honoured.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dds/dds.h"
#include "palp_types.h"

namespace palp::dds {

// Topic leaves under rt/palp/<rig>/ (ROS 2's "rt/" prefix: a ROS 2 node sees /palp/<rig>/...).
inline constexpr const char* kToolPose = "tool_pose";  // geometry_msgs PoseStamped, metres
inline constexpr const char* kWrench = "wrench";       // geometry_msgs WrenchStamped, N, N·m
inline constexpr const char* kFrames = "frames";       // palp::dds::HapticFrame, no contacts
inline constexpr const char* kFramesContacts = "frames_contacts";  // the same with contacts
inline constexpr const char* kFrameBatch = "frame_batch";  // palp::dds::FrameBatch: frames batched
inline constexpr const char* kScene = "scene";             // Encoded: palp.v1.SceneInfo
inline constexpr const char* kStats = "stats";             // Encoded: palp.v1.Stats
inline constexpr const char* kVolume = "volume";           // Encoded: palp.v1.VolumeChunk
inline constexpr const char* kDevicePose = "device_pose";  // palp::dds::DevicePose (controllers)
inline constexpr const char* kRigsTopic = "rt/palp/rigs";  // palp::dds::RigInfo, one per palpd

// "rt/palp/<rig>/<leaf>".
std::string topic_name(const std::string& rig, const char* leaf);
// The longest rig name, bytes. The keyed types (Encoded, RigInfo) carry `rig` as an unbounded
// string (palp_types.idl says why), so palp enforces this bound itself: palpd publishes only a
// valid rig (check_rig at start) and subscribers drop a received sample whose rig is not valid.
inline constexpr std::size_t kMaxRigBytes = 63;
// A rig name: 1..kMaxRigBytes of [A-Za-z0-9_], not starting with a digit (a ROS 2 topic name
// token).
bool valid_rig(const std::string& rig);
// The same for a string received from the domain (null: false): reads at most kMaxRigBytes + 1
// bytes of it, whatever its length.
bool valid_rig(const char* rig);
// `received` (a sample's rig) is valid and equals `rig`; reads at most kMaxRigBytes + 1 bytes.
bool same_rig(const char* received, const std::string& rig);
// UsageError saying what a rig name may be, unless valid.
void check_rig(const std::string& rig);
// The host name with every other character made '_' (a leading digit prefixed), or "palp".
std::string default_rig();
// A DDS domain id from text: 0..232 (UsageError otherwise).
std::uint32_t parse_domain(const std::string& text);

// `--dds [DOMAIN]` on a command line as "--dds" and "--dds-domain=DOMAIN" (also "--dds=DOMAIN"):
// the domain is optional, so the option parser sees a flag and a valued option.
std::vector<std::string> split_dds_domain(std::vector<std::string> argv);

// QoS of each kind of topic (docs/dds.md):
//   Stream    best-effort, keep-last(depth), volatile: haptic frames, pose, wrench
//   Latched   reliable, keep-last(depth) per instance, transient-local: scene, volume, stats,
//             rigs (late joiners get the last samples the writer holds)
//   Command   reliable, keep-last(depth), volatile: controller poses
enum class QosKind { Stream, Latched, Command };
struct QosDeleter {
  void operator()(dds_qos_t* q) const { dds_delete_qos(q); }
};
using QosPtr = std::unique_ptr<dds_qos_t, QosDeleter>;
QosPtr make_qos(QosKind kind, std::int32_t depth);

// An entity handle deleted (with its children) when it goes.
class Entity {
 public:
  Entity() = default;
  explicit Entity(dds_entity_t handle) : handle_(handle) {}
  ~Entity() { reset(); }
  Entity(Entity&& o) noexcept : handle_(o.handle_) { o.handle_ = 0; }
  Entity& operator=(Entity&& o) noexcept {
    if (this != &o) reset(), handle_ = o.handle_, o.handle_ = 0;
    return *this;
  }
  Entity(const Entity&) = delete;
  Entity& operator=(const Entity&) = delete;
  dds_entity_t get() const { return handle_; }
  void reset();

 private:
  dds_entity_t handle_ = 0;
};

// `result` when it is an entity, else ResourceError "<what>: <Cyclone's reason>".
dds_entity_t checked(dds_entity_t result, const std::string& what);
// A participant on `domain` with Cyclone's default (CYCLONEDDS_URI) configuration.
Entity make_participant(std::uint32_t domain);
// A topic named `name` of type `desc` in `participant`.
dds_entity_t make_topic(dds_entity_t participant, const dds_topic_descriptor_t* desc,
                        const std::string& name);

// Clocks: CLOCK_REALTIME now, and DDS/ROS 2 times from and to nanoseconds.
std::int64_t realtime_ns();
builtin_interfaces_msg_dds__Time_ to_time(std::int64_t ns);
std::int64_t from_time(const builtin_interfaces_msg_dds__Time_& t);

// A copy of a DDS string (null: ""); with `max`, of at most its first `max` bytes (reading no
// further).
inline std::string text(const char* s) {
  return s ? std::string(s) : std::string();
}
inline std::string text(const char* s, std::size_t max) {
  return s ? std::string(s, strnlen(s, max)) : std::string();
}

// A haptic frame as a frame_batch entry (palpd), and back (subscribers): the fields both types
// carry, kept in one place so the two directions change together. Contacts are not batched.
inline palp_dds_BatchFrame batch_frame_of(const palp_dds_HapticFrame& f) {
  return {f.frame_index,    f.seq,         f.server_time_ns, f.stamp, f.position,
          f.orientation,    f.force,       f.torque,         f.u,     f.n_contact,
          f.contact_points, f.tick_status, f.safety_status,  f.fault, f.device_state};
}
inline void set_from_batch_frame(const palp_dds_BatchFrame& b, palp_dds_HapticFrame& f) {
  f.frame_index = b.frame_index, f.seq = b.seq, f.server_time_ns = b.server_time_ns;
  f.stamp = b.stamp, f.position = b.position, f.orientation = b.orientation;
  f.force = b.force, f.torque = b.torque, f.u = b.u, f.n_contact = b.n_contact;
  f.contact_points = b.contact_points, f.tick_status = b.tick_status;
  f.safety_status = b.safety_status, f.fault = b.fault, f.device_state = b.device_state;
}

}  // namespace palp::dds
