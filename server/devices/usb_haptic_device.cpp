// The open-haptic USB device (devices/usb_haptic_device.hpp): handshake and frame handling on the
// libusb event thread, lock-free hand-off to and from the haptic loop.
#include "devices/usb_haptic_device.hpp"

#include <libusb.h>

#include <cstring>

#include "base/errors.hpp"

namespace palp::rt {

namespace ohp = usb::ohp;

UsbHapticDevice::UsbHapticDevice(Options options) : options_(std::move(options)) {}

UsbHapticDevice::~UsbHapticDevice() {
  if (link_) link_->stop();
}

DeviceStatus UsbHapticDevice::configure(const DeviceConfig& /*config*/) {
  return DeviceStatus::Ok;
}

DeviceStatus UsbHapticDevice::activate() {
  try {
    context_ = options_.context ? options_.context : std::make_shared<usb::UsbContext>();
    usb::LinkConfig config;
    config.id = options_.id;
    config.interface_number = options_.interface_number;
    config.in_endpoint = ohp::kEndpointIn;
    config.out_endpoint = ohp::kEndpointOut;
    config.in_packet_size = ohp::kDeviceFrameSize;
    config.out_packet_size = ohp::kHostFrameSize;
    config.on_open = [this](libusb_device_handle* handle) { return handshake(handle); };
    config.on_in = [this](const std::uint8_t* data, std::size_t size) { on_frame(data, size); };
    link_ = std::make_unique<usb::UsbLink>(context_, std::move(config));
    link_->start();
  } catch (const Error& e) {
    return fail(e.what());
  }
  active_ = true;
  return DeviceStatus::Ok;
}

DeviceStatus UsbHapticDevice::deactivate() {
  active_ = false;
  if (link_) {
    // A last frame with the force off, then close.
    context_->run_sync([this] {
      ohp::HostFrame frame;
      frame.seq = ++host_seq_;
      frame.echo = last_seq_;
      std::uint8_t bytes[ohp::kHostFrameSize];
      ohp::encode_host_frame(frame, bytes);
      link_->send(bytes, sizeof bytes);
    });
    link_->stop();
  }
  return DeviceStatus::Ok;
}

std::string UsbHapticDevice::handshake(libusb_device_handle* handle) {
  const auto itf = static_cast<std::uint16_t>(options_.interface_number);
  // bmRequestType: vendor request to the interface, IN (0xc1) or OUT (0x41).
  constexpr std::uint8_t in_type = 0xc1, out_type = 0x41;
  std::uint8_t buffer[64] = {};
  int rc =
      libusb_control_transfer(handle, in_type, ohp::kGetInfo, 0, itf, buffer, sizeof buffer, 500);
  if (rc < 0) return "GET_INFO failed: " + usb::error_text(rc);
  ohp::Info info;
  if (!ohp::decode_info(buffer, static_cast<std::size_t>(rc), info))
    return "not an open haptic device (GET_INFO gave " + std::to_string(rc) +
           " bytes without the PALP info block)";
  if (info.version_major != ohp::kVersionMajor)
    return "speaks open haptic protocol version " + std::to_string(info.version_major) + "." +
           std::to_string(info.version_minor) + ", palpd speaks " +
           std::to_string(ohp::kVersionMajor) + "." + std::to_string(ohp::kVersionMinor) +
           ": update the firmware or palpd";
  const bool pose = (info.capabilities & ohp::kCapPose) != 0;
  const bool joints =
      (info.capabilities & ohp::kCapJoints) != 0 && info.kinematics == ohp::kKinematicsCartesianRpy;
  if (!pose && !joints)
    return "declares neither pose frames nor a known kinematic model (capabilities 0x" +
           std::to_string(info.capabilities) + ", kinematic model " +
           std::to_string(info.kinematics) + ")";
  auto command = [&](std::uint8_t request, std::uint16_t value, const char* what) -> std::string {
    const int r = libusb_control_transfer(handle, out_type, request, value, itf, nullptr, 0, 500);
    return r < 0 ? std::string(what) + " failed: " + usb::error_text(r) : std::string();
  };
  std::string error;
  if (options_.watchdog_ms > 0 &&
      !(error = command(ohp::kSetWatchdog, static_cast<std::uint16_t>(options_.watchdog_ms),
                        "SET_WATCHDOG"))
           .empty())
    return error;
  if (!(error = command(ohp::kClearFaults, 0, "CLEAR_FAULTS")).empty()) return error;
  if (options_.home && (info.capabilities & ohp::kCapHoming) &&
      !(error = command(ohp::kHome, 0, "HOME")).empty())
    return error;
  if (!(error = command(ohp::kSetStream, 1, "SET_STREAM")).empty()) return error;
  info_ = info;
  declared_max_force_.store(static_cast<double>(info.max_force_uN) * 1e-6,
                            std::memory_order_relaxed);
  declared_stiffness_.store(static_cast<double>(info.max_stiffness_N_per_m) * 1e-3,
                            std::memory_order_relaxed);  // N/m -> N/mm
  declared_damping_.store(static_cast<double>(info.max_damping_mN_s_per_m) * 1e-6,
                          std::memory_order_relaxed);  // mN s/m -> N s/mm
  have_seq_ = false;
  clear_faults_ = false;
  prev_faults_ = 0;
  last_faults_.store(0, std::memory_order_relaxed);
  DeviceCommand stale;
  commands_.read(stale);  // a command from before the replug is not sent
  return {};
}

void UsbHapticDevice::on_frame(const std::uint8_t* data, std::size_t size) {
  ohp::DeviceFrame frame;
  const ohp::DecodeResult decoded = ohp::decode_device_frame(data, size, frame);
  if (decoded == ohp::DecodeResult::Short) {
    short_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  Incoming in;
  if (decoded != ohp::DecodeResult::Ok || !ohp::frame_pose(frame, info_.kinematics, in.pose)) {
    malformed_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  if (have_seq_ && frame.seq != last_seq_ + 1)
    gaps_.fetch_add(frame.seq - last_seq_ - 1, std::memory_order_relaxed);
  have_seq_ = true;
  last_seq_ = frame.seq;
  in.faults = frame.faults;
  in.status = frame.status;
  in.seq = frame.seq;
  if ((frame.faults & ohp::kFaultWatchdog) && !(prev_faults_ & ohp::kFaultWatchdog))
    trips_.fetch_add(1, std::memory_order_relaxed);
  prev_faults_ = frame.faults;
  frames_.fetch_add(1, std::memory_order_relaxed);
  last_echo_.store(frame.echo, std::memory_order_relaxed);
  last_faults_.store(frame.faults, std::memory_order_relaxed);
  last_status_.store(frame.status, std::memory_order_relaxed);
  buttons_.store(frame.buttons, std::memory_order_relaxed);
  incoming_.write(in);

  // Answer with the loop's newest command, once: no new command (the loop stalled) -> no frame,
  // and the device's watchdog takes the force off.
  DeviceCommand command;
  if (!commands_.read(command)) return;
  ohp::HostFrame out;
  out.seq = ++host_seq_;
  out.echo = frame.seq;
  // The last guard: never more than the device declares, the direction kept (the wire's own
  // per-axis saturation is never reached).
  const double declared = declared_max_force_.load(std::memory_order_relaxed);
  Vec3d force = is_finite(command.force) ? command.force : Vec3d{};
  if (declared > 0.0 && norm(force) > declared) force = force * (declared / norm(force));
  Vec3d torque = is_finite(command.torque) ? command.torque : Vec3d{};
  const double max_torque = static_cast<double>(info_.max_torque_mNmm) * 1e-3;  // N mm
  if (!(info_.capabilities & ohp::kCapTorque) || max_torque <= 0.0)
    torque = Vec3d{};
  else if (norm(torque) > max_torque)
    torque = torque * (max_torque / norm(torque));
  out.force_uN = ohp::to_uN(force);
  out.torque_mNmm = ohp::to_mNmm(torque);
  out.flags = ohp::kFlagEnable;
  // A watchdog trip clears itself once the host is back (the loop ramps the force in again);
  // other faults stay for a person to look at.
  if (frame.faults != 0 && (frame.faults & ~std::uint16_t(ohp::kFaultWatchdog)) == 0)
    out.flags |= ohp::kFlagClearFaults;
  std::uint8_t bytes[ohp::kHostFrameSize];
  ohp::encode_host_frame(out, bytes);
  if (link_->send(bytes, sizeof bytes)) host_frames_.fetch_add(1, std::memory_order_relaxed);
}

DeviceStatus UsbHapticDevice::read(std::int64_t /*now_ns*/, DeviceSample& sample) noexcept {
  if (!active_ || !link_) return DeviceStatus::Disconnected;
  if (link_->state() != usb::LinkState::Present) {
    have_frame_ = false;
    Incoming stale;
    incoming_.read(stale);  // frames from before the loss are not used after a replug
    return DeviceStatus::Absent;
  }
  Incoming in;
  if (!incoming_.read(in)) return DeviceStatus::NoData;
  last_ = in;
  have_frame_ = true;
  sample.pose = in.pose;
  sample.forced_fault = 0;
  if (in.faults & ~std::uint16_t(ohp::kFaultWatchdog)) return DeviceStatus::Error;
  if (in.faults & ohp::kFaultWatchdog) return DeviceStatus::Timeout;
  if (in.status & ohp::kStatusHoming) return DeviceStatus::NoData;
  return DeviceStatus::Ok;
}

DeviceStatus UsbHapticDevice::write(const DeviceCommand& command) noexcept {
  if (!active_ || !link_) return DeviceStatus::Disconnected;
  commands_.write(command);
  return DeviceStatus::Ok;
}

DeviceState UsbHapticDevice::state() const noexcept {
  if (!link_) return DeviceState::Absent;
  switch (link_->state()) {
    case usb::LinkState::Present:
      return last_faults_.load(std::memory_order_relaxed) != 0 ? DeviceState::Fault
                                                               : DeviceState::Present;
    case usb::LinkState::Fault:
      return DeviceState::Fault;
    case usb::LinkState::Absent:
    case usb::LinkState::Unknown:  // a link is never unknown
      break;
  }
  return DeviceState::Absent;
}

usb::LinkState UsbHapticDevice::link_state() const noexcept {
  return link_ ? link_->state() : usb::LinkState::Absent;
}

std::string UsbHapticDevice::status_message() const {
  std::string text = link_ ? link_->message() : "usb-haptic not active";
  const std::uint16_t faults = last_faults_.load(std::memory_order_relaxed);
  if (link_ && link_->state() == usb::LinkState::Present && faults != 0) {
    text += "; device faults 0x";
    static const char* digits = "0123456789abcdef";
    for (int shift = 12; shift >= 0; shift -= 4) text += digits[(faults >> shift) & 15];
    if (faults & ohp::kFaultWatchdog) text += " (watchdog: host frames stopped)";
  }
  return text;
}

UsbHapticDevice::Counters UsbHapticDevice::counters() const noexcept {
  Counters c;
  c.frames = frames_.load(std::memory_order_relaxed);
  c.short_packets = short_.load(std::memory_order_relaxed);
  c.malformed = malformed_.load(std::memory_order_relaxed);
  c.seq_gaps = gaps_.load(std::memory_order_relaxed);
  c.host_frames = host_frames_.load(std::memory_order_relaxed);
  c.watchdog_trips = trips_.load(std::memory_order_relaxed);
  c.opens = link_ ? link_->opens() : 0;
  c.last_echo = last_echo_.load(std::memory_order_relaxed);
  c.last_faults = last_faults_.load(std::memory_order_relaxed);
  c.last_status = last_status_.load(std::memory_order_relaxed);
  c.buttons = buttons_.load(std::memory_order_relaxed);
  return c;
}

}  // namespace palp::rt
