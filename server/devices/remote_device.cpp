// remote: the device pose comes from a CONTROLLER client over the network.
#include "devices/device.hpp"

namespace palp::rt {

DeviceStatus RemoteDevice::configure(const DeviceConfig& config) {
  if (!(config.timeout_s > 0.0)) return fail("remote: the timeout must be positive");
  timeout_ns_ = static_cast<std::int64_t>(config.timeout_s * 1e9);
  return DeviceStatus::Ok;
}

DeviceStatus RemoteDevice::activate() {
  have_pose_ = false;
  absent_.store(false, std::memory_order_relaxed);
  return DeviceStatus::Ok;
}

DeviceStatus RemoteDevice::read(std::int64_t now_ns, DeviceSample& sample) noexcept {
  Timed fresh;
  if (box_.read(fresh)) {
    last_ = fresh;
    have_pose_ = true;
    absent_.store(false, std::memory_order_relaxed);
    sample.pose = last_.pose;
    sample.forced_fault = 0;
    return DeviceStatus::Ok;
  }
  if (absent_.load(std::memory_order_relaxed)) return DeviceStatus::Absent;
  if (!have_pose_) return DeviceStatus::NoData;
  if (now_ns - last_.t_ns > timeout_ns_) {
    // the driver stopped sending (its controller left): the device is gone, as an unplugged USB
    // device is, not failing every tick
    have_pose_ = false;
    absent_.store(true, std::memory_order_relaxed);
    return DeviceStatus::Absent;
  }
  return DeviceStatus::NoData;
}

DeviceStatus RemoteDevice::write(const DeviceCommand& command) noexcept {
  command_box_.write(command);
  return DeviceStatus::Ok;
}

DeviceStatus RemoteDevice::deactivate() {
  return DeviceStatus::Ok;
}

void RemoteDevice::submit(const Pose& pose, std::int64_t received_ns) noexcept {
  box_.write(Timed{pose, received_ns});
}

DeviceCommand RemoteDevice::last_command() noexcept {
  command_box_.read(command_seen_);
  return command_seen_;
}

}  // namespace palp::rt
