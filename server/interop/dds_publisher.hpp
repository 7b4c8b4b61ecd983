// palpd on DDS (Eclipse Cyclone DDS; topics, QoS and types in docs/dds.md): a publisher on a
// thread of its own, fed by the palp.v1 network thread's snapshot tap, never by the loop.
//
//   io thread: offer(snapshot)  keeps one snapshot per 1/rate of loop time (every tick with rate
//                               0), copies it into a preallocated ring (full: dropped, counted)
//                               and signals an eventfd; never waits, never allocates
//   DDS thread                  drains the ring: HapticFrame (without and with contacts),
//                               PoseStamped and WrenchStamped per snapshot, FrameBatch per
//                               batch_ms of loop time (dds_batch.hpp) (best-effort,
//                               keep-last; a topic without readers is skipped); Stats every stats
//                               interval and SceneInfo again when it changed (reliable,
//                               transient-local); with control, the device poses of
//                               rt/palp/<rig>/device_pose whose token matches (compared in constant
//                               time)
//
// The rig announcement, SceneInfo and the render volume are prepared in the constructor (before
// the loop starts) and written by start(); the writers keep them for late joiners.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "loop/haptic_loop.hpp"
#include "net/control_target.hpp"
#include "net/server.hpp"
#include "rt/snapshot.hpp"

namespace palp::interop {

struct DdsConfig {
  std::uint32_t domain = 0;
  std::string rig = "palp";
  double rate_hz = 0;      // frames per second of loop time (0: every tick)
  std::int32_t depth = 4;  // keep-last depth of the frame, pose and wrench writers
  double batch_ms = 10;    // frame_batch: the frames of this much loop time per sample (0: none)
  double stats_interval_s = 1.0;       // Stats (and a look for a changed scene) this often
  std::uint32_t volume_max_dim = 128;  // render volume: voxels per axis at most (0: none)
  std::size_t queue = 1024;  // snapshots between the io thread and the DDS thread (1 s at 1 kHz)
  bool control = false;     // read rt/palp/<rig>/device_pose
  std::string token;        // with control: the token a DevicePose must carry
  bool report = true;       // a line of counters on stdout when it stops
};

struct DdsCounters {
  std::uint64_t offered =
      0;  // frame indices given: kept by offer(), and every tick ticks lost before
  std::uint64_t dropped = 0;    // the ring to the DDS thread was full
  std::uint64_t published = 0;  // HapticFrames written
  std::uint64_t batches = 0;    // FrameBatches written
  std::uint64_t write_errors = 0;
  std::uint64_t scene_versions = 0;
  std::uint64_t volume_chunks = 0;
  std::uint64_t poses_accepted = 0;
  std::uint64_t poses_refused = 0;  // wrong token, wrong rig, or a device that is not remote
  std::uint32_t subscribers = 0;    // readers matched on the frames topics now (batch included)
};

class DdsPublisher {
 public:
  // Joins the domain, creates the writers and prepares the latched samples (ResourceError when
  // Cyclone refuses). `control`: where device poses go (with config.control).
  DdsPublisher(DdsConfig config, const net::SceneDescription& scene, rt::HapticLoop& loop,
               net::ControlTarget* control, std::string host, std::string tool);
  ~DdsPublisher();  // stop(); the rig is disposed
  DdsPublisher(const DdsPublisher&) = delete;
  DdsPublisher& operator=(const DdsPublisher&) = delete;

  const DdsConfig& config() const;
  void start();
  void stop();  // idempotent
  // One thread only (the palp.v1 io thread): never waits, never allocates.
  void offer(const rt::Snapshot& snapshot) noexcept;
  DdsCounters counters() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palp::interop
