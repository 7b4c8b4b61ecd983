// sim and sim:FILE: a trajectory played in real time, looping. The row shown at time t after
// activation is the last one whose timestamp (relative to the first row) is <= t modulo the
// path's period (its duration plus one row interval, so the loop does not repeat a row).
#include <cmath>

#include "base/errors.hpp"
#include "devices/device.hpp"
#include "scene/trajectory_gen.hpp"

namespace palp::rt {

Trajectory builtin_palpation_path(const FieldSampler& fields, const Tool& tool) {
  const double offset = pad_offset(tool);
  try {
    RibsSpec ribs;  // press, slide along the body axis across the ribs, lift
    ribs.rate_hz = 1000.0;
    return ribs_slide(fields, offset, ribs);
  } catch (const InputError&) {
    // Not a torso-like scene: press and hold on the patient's anterior skin, with a slide.
    PressHoldSpec hold;
    hold.rate_hz = 1000.0;
    hold.shift_mm = 10.0;
    hold.hold_s = 1.0;
    Trajectory path = press_hold(find_surface_anchor(fields, ApproachSide::Auto), offset, hold);
    // Lift back out along the path's own first pose so the loop starts above the skin again.
    const Trajectory::size_type n = path.size();
    const TrajectorySample first = path.front();
    const double t_end = path.back().t;
    for (Trajectory::size_type i = 1; i <= n / 4; ++i) {
      const double a = static_cast<double>(i) / static_cast<double>(n / 4);
      TrajectorySample s = path[n - 1];
      s.t = t_end + static_cast<double>(i) / hold.rate_hz;
      s.pose.position = (1.0 - a) * path[n - 1].pose.position + a * first.pose.position;
      path.push_back(s);
    }
    return path;
  }
}

SimDevice::SimDevice(Trajectory trajectory) : trajectory_(std::move(trajectory)) {}

DeviceStatus SimDevice::configure(const DeviceConfig& config) {
  try {
    if (trajectory_.empty()) {
      if (!config.fields) return fail("sim: the built-in path needs a scene");
      trajectory_ = builtin_palpation_path(*config.fields, config.tool);
    }
  } catch (const Error& e) {
    return fail(std::string("sim: ") + e.what());
  }
  if (trajectory_.empty()) return fail("sim: empty trajectory");
  const double span = trajectory_.back().t - trajectory_.front().t;
  const double step = trajectory_.size() > 1 ? span / static_cast<double>(trajectory_.size() - 1)
                                             : 1.0 / config.rate_hz;
  period_s_ = span + step;
  return DeviceStatus::Ok;
}

std::optional<Trajectory> SimDevice::scripted_path(const FieldSampler& fields,
                                                  const Tool& tool) const {
  return trajectory_.empty() ? builtin_palpation_path(fields, tool) : trajectory_;
}

DeviceStatus SimDevice::activate() {
  if (trajectory_.empty()) return fail("sim: not configured");
  active_ = true;
  started_ = false;
  cursor_ = 0;
  cursor_lap_ = 0.0;
  return DeviceStatus::Ok;
}

DeviceStatus SimDevice::read(std::int64_t now_ns, DeviceSample& sample) noexcept {
  if (!active_) return DeviceStatus::Disconnected;
  if (!started_) {
    started_ = true;
    start_ns_ = now_ns;
  }
  const double elapsed = static_cast<double>(now_ns - start_ns_) * 1e-9;
  const double lap = std::floor(elapsed / period_s_);
  const double t = trajectory_.front().t + (elapsed - lap * period_s_);
  if (lap != cursor_lap_) {
    cursor_ = 0;
    cursor_lap_ = lap;
  }
  while (cursor_ + 1 < trajectory_.size() && trajectory_[cursor_ + 1].t <= t) ++cursor_;
  sample.pose = trajectory_[cursor_].pose;
  sample.forced_fault = 0;
  return DeviceStatus::Ok;
}

DeviceStatus SimDevice::write(const DeviceCommand& command) noexcept {
  last_command_ = command;
  ++writes_;
  return active_ ? DeviceStatus::Ok : DeviceStatus::Disconnected;
}

DeviceStatus SimDevice::deactivate() {
  active_ = false;
  return DeviceStatus::Ok;
}

}  // namespace palp::rt
