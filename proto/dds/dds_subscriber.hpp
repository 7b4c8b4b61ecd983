// One rig's topics as a subscriber sees them: what `palp probe --dds` and palpview's DDS source
// read (docs/dds.md). Readers with the QoS their writers offer (dds_common.hpp), a wait-set, and
// take(): every sample that arrived, handed to the matching function while it is on loan from
// Cyclone (copy what you keep). list_rigs(): the rigs announced on a domain.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "dds_common.hpp"
#include "ros2_types.h"

namespace palp::dds {

struct SubscriberOptions {
  std::uint32_t domain = 0;
  std::string rig = "palp";
  bool frames = true;     // rt/palp/<rig>/frames
  bool contacts = false;  // frames_contacts instead (each frame with its contacts)
  bool batch = false;     // frame_batch instead: each batch's frames handed to Handlers::frame
  bool ros = false;       // tool_pose and wrench
  bool scene = true, stats = true;  // scene and stats
  bool volume = false;              // volume (the render volume, chunk by chunk)
  std::int32_t frame_depth = 256;   // frames (batches) kept for this reader between two take()s
};

struct Handlers {
  // `rx_ns`: CLOCK_REALTIME when take() got the batch. With SubscriberOptions::batch, frames
  // from frame_batch in the same type (rig set, no contacts).
  std::function<void(const palp_dds_HapticFrame&, std::int64_t rx_ns)> frame;
  std::function<void(const geometry_msgs_msg_dds__PoseStamped_&, std::int64_t rx_ns)> pose;
  std::function<void(const geometry_msgs_msg_dds__WrenchStamped_&, std::int64_t rx_ns)> wrench;
  // `leaf`: kScene, kStats or kVolume.
  std::function<void(const char* leaf, const palp_dds_Encoded&)> encoded;
};

class RigSubscriber {
 public:
  explicit RigSubscriber(const SubscriberOptions& options);  // ResourceError, UsageError
  RigSubscriber(const RigSubscriber&) = delete;
  RigSubscriber& operator=(const RigSubscriber&) = delete;

  // Waits up to `timeout_s` for a sample on any reader; false when none came.
  bool wait(double timeout_s);
  // Every sample that arrived, oldest first per topic. Returns how many.
  std::size_t take(const Handlers& handlers);
  // Writers matched on the frames (or frame_batch) topic now (0: no palpd publishing this rig's
  // frames).
  std::uint32_t frame_writers() const;
  const SubscriberOptions& options() const { return options_; }
  std::uint64_t batches() const { return batches_; }  // FrameBatches taken so far
  // Scene, stats and volume samples dropped because their rig was not options().rig (or not a
  // valid rig name at all).
  std::uint64_t foreign() const { return foreign_; }

 private:
  SubscriberOptions options_;
  Entity participant_;
  dds_entity_t waitset_ = 0;
  std::uint64_t batches_ = 0, foreign_ = 0;
  dds_entity_t batch_ = 0, frames_ = 0, pose_ = 0, wrench_ = 0, scene_ = 0, stats_ = 0, volume_ = 0;
};

struct RigSeen {
  std::string rig, host, scene, tool, device;
  std::uint32_t pid = 0;
  double rate_hz = 0;
  bool control = false;
  bool alive = true;  // false: its palpd said goodbye (disposed) or vanished
  std::int64_t started_ns = 0;
};
// The longest host, scene, tool or device name list_rigs keeps (longer ones are cut).
inline constexpr std::size_t kMaxRigText = 1024;
// The rigs announced on `domain` within `listen_s` seconds (late joiners get them at once; the
// wait is for discovery), by name; at most 64 samples, those with an invalid rig name ignored.
std::vector<RigSeen> list_rigs(std::uint32_t domain, double listen_s);

}  // namespace palp::dds
