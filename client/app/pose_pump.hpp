// The controller's pose pump: poses leave at a steady kPosePumpHz from their own thread, whatever
// the render rate. palpd's remote device faults after 100 ms without a pose, and a software
// renderer (llvmpipe) draws only a few frames per second. The render thread hands over the pose
// the input produced; a --script is sampled here, at the pump's rate, not at the frame rate.
#pragma once

#include <atomic>
#include <chrono>
#include <mutex>
#include <optional>
#include <thread>

#include "scene/trajectory.hpp"
#include "stream/stream_client.hpp"

namespace palp::view {

inline constexpr double kPosePumpHz = 250.0;

// The pose of a trajectory at time t (the last row with t_row <= t; the first before it).
Pose script_pose(const Trajectory& script, double t);

class PosePump {
 public:
  using Clock = std::chrono::steady_clock;

  // Starts the thread; it sends nothing until the first set(). `client` and `script` must
  // outlive the pump.
  PosePump(StreamClient& client, const Trajectory& script);
  ~PosePump();  // stops and joins
  PosePump(const PosePump&) = delete;
  PosePump& operator=(const PosePump&) = delete;

  // The pose to send from now on; with a script, the script's pose at the time since
  // `live_since` instead (kept from an earlier call when unset here).
  void set(const Pose& pose, std::optional<Clock::time_point> live_since);

 private:
  void pump();

  StreamClient& client_;
  const Trajectory& script_;
  std::mutex mutex_;
  Pose pose_{};
  bool have_pose_ = false;
  std::optional<Clock::time_point> live_since_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace palp::view
