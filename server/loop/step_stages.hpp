// The pure stages of HapticLoop::step (haptic_loop.cpp): what a tick decides from values alone,
// with no device, clock or atomic, so each is tested by itself (tests/server/loop/
// step_stages_test.cpp). The stages that touch the device or the shared counters stay members of
// the loop and call these.
#pragma once

#include <cstdint>

#include "devices/device.hpp"
#include "model/registration.hpp"
#include "rt/snapshot.hpp"

namespace palp::rt {

// Why a tick's force was zeroed (TickRecord::fault). The low byte are faults.
enum LoopFault : std::uint32_t {
  kFaultNone = 0,
  kFaultDeadline = 1u << 0,       // the tick started too late (watchdog bound)
  kFaultDeviceTimeout = 1u << 1,  // the device did not answer in time
  kFaultDeviceLost = 1u << 2,     // the device is disconnected or failed
  kFaultDeviceWrite = 1u << 3,    // writing the force failed
  kFaultMask = 0xffu,
  kZeroPaused = 1u << 8,         // paused by a command: zero force, model not ticked
  kZeroNoPose = 1u << 9,         // no pose from the device yet
  kZeroDeviceAbsent = 1u << 10,  // the device is not plugged in (hot-plug; not a fault)
};

// watchdog: lateness -> kFaultDeadline when the tick started more than `watchdog_ns` after its
// deadline (0: off).
constexpr std::uint32_t watchdog_bits(std::int64_t late_ns, std::int64_t watchdog_ns) noexcept {
  return watchdog_ns > 0 && late_ns > watchdog_ns ? kFaultDeadline : kFaultNone;
}

// read_device: the device's answer -> the tick's zero bits. `since_sample_ns`: the time from the
// last fresh pose to this tick's deadline; NoData past `timeout_ns` (0: off) is a timeout once a
// pose was had. Finished stops the loop (no bits: the caller handles it).
constexpr std::uint32_t read_bits(DeviceStatus status, std::uint32_t forced_fault, bool have_pose,
                                  std::int64_t since_sample_ns, std::int64_t timeout_ns) noexcept {
  switch (status) {
    case DeviceStatus::Ok:
      return forced_fault;
    case DeviceStatus::NoData:
      return have_pose && timeout_ns > 0 && since_sample_ns > timeout_ns ? kFaultDeviceTimeout
                                                                         : kFaultNone;
    case DeviceStatus::Timeout:
      return kFaultDeviceTimeout;
    case DeviceStatus::Finished:
      return kFaultNone;
    case DeviceStatus::Disconnected:
    case DeviceStatus::Error:
      return kFaultDeviceLost;
    case DeviceStatus::Absent:
      return kZeroDeviceAbsent;
  }
  return kFaultNone;
}

// recentre: a requested re-centre happens only with a pose, out of contact (the force cannot
// step) and with a registration to move.
constexpr bool may_recentre(bool requested, bool have_pose, std::int32_t contacts,
                            bool identity) noexcept {
  return requested && have_pose && contacts == 0 && !identity;
}

// recentre: the registration's home that maps the device point `device_position` onto
// `configured_home` (like lifting a mouse).
inline Vec3d recentred_home(const Registration& r, const Vec3d& configured_home,
                            const Vec3d& device_position) noexcept {
  return configured_home - point_to_scene(Registration{r.rotation, r.scale, {}}, device_position);
}

// device_presence: the device state a snapshot carries; Absent when this tick's read said so,
// even while the device's own state() still says Present.
constexpr DeviceState presence(std::uint32_t zero, DeviceState reported) noexcept {
  return (zero & kZeroDeviceAbsent) && reported == DeviceState::Present ? DeviceState::Absent
                                                                        : reported;
}

// idle: no pose yet or paused -> their zero bits (the force is zeroed, the model not ticked).
constexpr std::uint32_t idle_bits(bool have_pose, bool paused) noexcept {
  return (have_pose ? kFaultNone : kZeroNoPose) | (paused ? kZeroPaused : kFaultNone);
}

}  // namespace palp::rt
