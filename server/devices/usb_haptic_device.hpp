// `--device usb-haptic[:VID:PID]`: a force-feedback device speaking the open haptic protocol
// (open_haptic_protocol.hpp, docs/usb-protocol.md) over libusb, hot-plug safe.
//
// Data flow:
//   device frame (IN, ≥1 kHz) ─► UsbLink (event thread) ─► decode, check, count ─► LatestBox ─►
//   read() in the loop: the newest pose, or Absent / NoData / Timeout (device watchdog) / Error
//   write() in the loop ─► LatestBox ─► answered in the event thread with the next device frame:
//   one host frame (force, torque, enable, echo of the device seq) per loop command, never a stale
//   one again, so a stalled loop stops the host frames and the device's watchdog drops the force.
// Unplugged: the link says Absent at once and read() answers DeviceStatus::Absent (the loop writes
// zero that tick and keeps running); replugged: handshake again, frames resume.
// read() and write() only touch atomics and LatestBoxes: no allocation, lock, log or throw.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "devices/device.hpp"
#include "rt/snapshot.hpp"
#include "usb/open_haptic_protocol.hpp"
#include "usb/usb_context.hpp"

namespace palp::rt {

class UsbHapticDevice final : public Device {
 public:
  struct Options {
    usb::UsbId id{usb::ohp::kDefaultVendor, usb::ohp::kDefaultProduct};
    unsigned watchdog_ms = 20;  // sent with SET_WATCHDOG (0: keep the device's own)
    bool home = true;           // send HOME when the device declares kCapHoming
    int interface_number = 0;
    std::shared_ptr<usb::UsbContext> context;  // null: activate() makes one
  };
  explicit UsbHapticDevice(Options options);
  ~UsbHapticDevice() override;

  std::string_view kind() const noexcept override { return "usb-haptic"; }
  bool drives_a_hand() const noexcept override { return true; }
  DeviceStatus configure(const DeviceConfig& config) override;
  DeviceStatus activate() override;  // Ok also when the device is not plugged in yet
  DeviceStatus read(std::int64_t now_ns, DeviceSample& sample) noexcept override;
  DeviceStatus write(const DeviceCommand& command) noexcept override;
  DeviceStatus deactivate() override;
  DeviceState state() const noexcept override;
  std::string status_message() const override;
  // The buttons the device last reported (bit 0 marks a training task's spot, rt::kMarkButton).
  std::uint32_t buttons() const noexcept override {
    return buttons_.load(std::memory_order_relaxed);
  }

  // Counters (any thread).
  struct Counters {
    std::uint64_t frames = 0;          // valid device frames
    std::uint64_t short_packets = 0;   // shorter than a frame: ignored
    std::uint64_t malformed = 0;       // bad type, version, CRC or pose: ignored
    std::uint64_t seq_gaps = 0;        // device frames missed (seq jumps)
    std::uint64_t host_frames = 0;     // force frames sent
    std::uint64_t watchdog_trips = 0;  // the device reported its watchdog fault (rising edges)
    std::uint64_t opens = 0;           // successful handshakes (1 + replugs)
    std::uint32_t last_echo = 0;       // the host seq the device last applied
    std::uint16_t last_faults = 0;
    std::uint16_t last_status = 0;
    std::uint16_t buttons = 0;
  };
  Counters counters() const noexcept;
  usb::LinkState link_state() const noexcept;
  const usb::ohp::Info& info() const { return info_; }  // valid once Present
  // What GET_INFO declared (force; stiffness and damping from protocol 1.1), from the first
  // handshake on.
  DeclaredLimits declared_limits() const noexcept override {
    return {declared_max_force_.load(std::memory_order_relaxed),
            declared_stiffness_.load(std::memory_order_relaxed),
            declared_damping_.load(std::memory_order_relaxed)};
  }

 private:
  struct Incoming {
    Pose pose{};
    std::uint16_t faults = 0;
    std::uint16_t status = 0;
    std::uint32_t seq = 0;
  };
  std::string handshake(libusb_device_handle* handle);
  void on_frame(const std::uint8_t* data, std::size_t size);

  Options options_;
  std::shared_ptr<usb::UsbContext> context_;
  std::unique_ptr<usb::UsbLink> link_;
  usb::ohp::Info info_{};
  LatestBox<Incoming> incoming_;
  LatestBox<DeviceCommand> commands_;
  bool active_ = false;

  // Event thread.
  bool have_seq_ = false;
  std::uint32_t last_seq_ = 0;
  std::uint32_t host_seq_ = 0;
  bool clear_faults_ = false;
  std::uint16_t prev_faults_ = 0;
  DeviceCommand pending_{};

  // Loop thread.
  Incoming last_{};
  bool have_frame_ = false;

  std::atomic<std::uint64_t> frames_{0}, short_{0}, malformed_{0}, gaps_{0}, host_frames_{0},
      trips_{0};
  std::atomic<std::uint32_t> last_echo_{0};
  std::atomic<double> declared_max_force_{0.0}, declared_stiffness_{0.0}, declared_damping_{0.0};
  std::atomic<std::uint16_t> last_faults_{0}, last_status_{0}, buttons_{0};
};

}  // namespace palp::rt
