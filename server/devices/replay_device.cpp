// replay:FILE: a recording's poses, one record per tick, with the recorded zero-force ticks
// reproduced through DeviceSample::forced_fault.
#include "devices/device.hpp"

namespace palp::rt {

ReplayDevice::ReplayDevice(std::vector<TickRecord> records) : records_(std::move(records)) {}

DeviceStatus ReplayDevice::configure(const DeviceConfig&) {
  if (records_.empty()) return fail("replay: the recording has no ticks");
  return DeviceStatus::Ok;
}

DeviceStatus ReplayDevice::activate() {
  next_ = 0;
  active_ = true;
  return DeviceStatus::Ok;
}

DeviceStatus ReplayDevice::read(std::int64_t, DeviceSample& sample) noexcept {
  if (!active_) return DeviceStatus::Disconnected;
  if (next_ >= records_.size()) return DeviceStatus::Finished;
  const TickRecord& r = records_[next_++];
  sample.pose = r.pose;
  sample.forced_fault = r.fault;
  return DeviceStatus::Ok;
}

DeviceStatus ReplayDevice::write(const DeviceCommand&) noexcept {
  return active_ ? DeviceStatus::Ok : DeviceStatus::Disconnected;
}

DeviceStatus ReplayDevice::deactivate() {
  active_ = false;
  return DeviceStatus::Ok;
}

}  // namespace palp::rt
