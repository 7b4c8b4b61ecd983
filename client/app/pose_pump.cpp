// The controller's pose pump (see the header).
#include "app/pose_pump.hpp"

namespace palp::view {

Pose script_pose(const Trajectory& script, double t) {
  std::size_t n = 0;
  while (n + 1 < script.size() && script[n + 1].t <= t) ++n;
  return script[n].pose;
}

PosePump::PosePump(StreamClient& client, const Trajectory& script)
    : client_(client), script_(script) {
  thread_ = std::thread([this] { pump(); });
}

PosePump::~PosePump() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

void PosePump::set(const Pose& pose, std::optional<Clock::time_point> live_since) {
  const std::lock_guard<std::mutex> lock(mutex_);
  pose_ = pose;
  have_pose_ = true;
  if (live_since) live_since_ = live_since;
}

void PosePump::pump() {
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / kPosePumpHz));
  auto next = Clock::now();
  while (!stop_.load()) {
    next += period;
    std::this_thread::sleep_until(next);
    Pose pose;
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (!have_pose_) continue;
      pose = !script_.empty() && live_since_
                 ? script_pose(script_,
                               std::chrono::duration<double>(Clock::now() - *live_since_).count())
                 : pose_;
    }
    client_.send_pose(pose);
  }
}

}  // namespace palp::view
