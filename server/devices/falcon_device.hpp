// `--device falcon[:INDEX]`: a Novint Falcon driven directly through libusb-1.0, hot-plug safe.
//
// Setup (UsbLink::on_open, event thread, synchronous transfers): FTDI bridge reset and purge; a
// probe frame at the runtime baud rate detects firmware that is already running (then nothing is
// loaded); otherwise the DSP bootloader handshake and the firmware upload in 62-byte chunks, each
// echoed and compared byte for byte, the whole load retried a bounded number of times; then the
// runtime settings and a check that the firmware answers frames. Every failure becomes the link's
// Fault message (no device, permission with the udev rule, handshake, echo mismatch, silence).
//
// Runtime, strictly request / reply (falcon_protocol.hpp):
//   loop write(force) ─► efforts (Jacobian transpose at the last position, clamped) ─► LatestBox
//   event thread: every IN packet (the FTDI bridge sends one each latency ms, 1 ms) ─► strip the
//   2 status bytes ─► FrameParser (resync, counters) ─► LatestBox ─► loop read(): forward
//   kinematics (Newton) ─► pose in palp's device frame (workspace centre = origin, fixed tool
//   orientation). A reply received (or overdue) and a fresh command ─► one host frame. No command
//   for stall_ms (the loop stopped) ─► a zero-effort frame.
// Homing: until the firmware reports all three motors homed, the host frames ask for homing
// with the red LED, read() answers Absent (the loop sends no force) and status_message() tells
// the user to pull the handle all the way out and push it straight in; once homed the LED turns
// green and the loop engages with its ramp. The centre grip button is a clutch: held, read()
// answers Absent (no force) and the handle moves without moving the tool; released, the tool goes
// on from where it was (the loop ramps the force back in). The forward button re-centres: held,
// no force; released, the handle's position becomes the workspace centre (the tool goes to the
// home point) and the loop ramps the force in.
// read() and write() touch only atomics, LatestBoxes and pure kinematics: no allocation, lock,
// log or throw.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "devices/device.hpp"
#include "devices/falcon_kinematics.hpp"
#include "rt/snapshot.hpp"
#include "usb/falcon_protocol.hpp"
#include "usb/usb_context.hpp"

namespace palp::rt {

class FalconDevice final : public Device {
 public:
  struct Options {
    unsigned index = 0;                  // falcon:INDEX, the INDEX-th Falcon on the bus
    std::vector<std::uint8_t> firmware;  // Novint's firmware image (set_firmware)
    std::string firmware_path;           // for messages
    int upload_attempts = 3;             // whole loads tried before the device is refused
    Quat tool_orientation{};             // device frame: the fixed orientation of the 3-DOF tool
    unsigned reply_timeout_ms = 20;      // a reply not back by then is counted lost, resent
    unsigned stall_ms = 10;              // no loop command for this long: zero-effort frames
    std::shared_ptr<usb::UsbContext> context;  // null: activate() makes one
  };
  explicit FalconDevice(Options options);
  ~FalconDevice() override;

  // Reads and checks the firmware file: InputError (missing, unreadable, empty, too large).
  static std::vector<std::uint8_t> read_firmware(const std::string& path);
  void set_firmware(std::vector<std::uint8_t> image, std::string path);
  void set_tool_orientation(const Quat& q) { options_.tool_orientation = q; }
  const Quat& tool_orientation() const { return options_.tool_orientation; }
  // deactivate() prints one line to stderr: exchanges per second and the error counters (palpd
  // sets it unless --quiet; the exchange rate on real hardware is otherwise unmeasured).
  void set_report_at_stop(bool report) { report_at_stop_ = report; }

  std::string_view kind() const noexcept override { return "falcon"; }
  bool drives_a_hand() const noexcept override { return true; }
  std::string_view own_profile() const noexcept override { return "falcon"; }
  DeviceStatus configure(const DeviceConfig& config) override;  // Error without firmware
  DeviceStatus activate() override;  // Ok also when no Falcon is plugged in yet
  DeviceStatus read(std::int64_t now_ns, DeviceSample& sample) noexcept override;
  DeviceStatus write(const DeviceCommand& command) noexcept override;
  DeviceStatus deactivate() override;
  DeviceState state() const noexcept override;
  std::string status_message() const override;
  // The grip's buttons (bit 0 PLUS marks a training task's spot, rt::kMarkButton).
  std::uint32_t buttons() const noexcept override {
    return buttons_.load(std::memory_order_relaxed);
  }
  // CHAI3D's Falcon class (cFalconDevice): 8 N, 3 N/mm, 20 N s/m.
  DeclaredLimits declared_limits() const noexcept override { return {8.0, 3.0, 0.020}; }

  struct Counters {
    std::uint64_t frames = 0;           // valid device frames (= completed exchanges)
    std::uint64_t corrupt = 0;          // frames with a byte out of range or no '>' at 16
    std::uint64_t short_frames = 0;     // frames cut short (resynced on the next '<')
    std::uint64_t short_packets = 0;    // IN packets shorter than the FTDI status
    std::uint64_t host_frames = 0;      // host frames sent
    std::uint64_t zero_frames = 0;      // of them, zero efforts sent because the loop stalled
    std::uint64_t lost_replies = 0;     // requests with no reply within reply_timeout_ms
    std::uint64_t clamped = 0;          // commands scaled down to falcon::kMaxEffort a motor
    std::uint64_t fk_failures = 0;      // encoder readings forward kinematics could not solve
    std::uint64_t uploads = 0;          // firmware loads that succeeded
    std::uint64_t upload_failures = 0;  // load attempts that failed (handshake, echo, silence)
    std::uint64_t already_running = 0;  // opens that found the firmware running
    std::uint64_t opens = 0;            // setups completed (1 + replugs)
    std::uint64_t recentres = 0;        // forward-button re-centres
    std::uint8_t buttons = 0;
    std::uint8_t homed = 0;  // bit per motor, from the last frame
    std::array<std::int16_t, 3> last_efforts{};
  };
  Counters counters() const noexcept;
  DeviceLinkCounters link_counters() const noexcept override {
    return {frames_.load(std::memory_order_relaxed), corrupt_.load(std::memory_order_relaxed),
            short_frames_.load(std::memory_order_relaxed), lost_.load(std::memory_order_relaxed),
            clamped_.load(std::memory_order_relaxed)};
  }
  usb::LinkState link_state() const noexcept;
  // All three motors homed, as the firmware last said (false while absent).
  bool homed() const noexcept { return (homed_bits_.load(std::memory_order_relaxed) & 7) == 7; }
  // The last end-effector position in the Falcon frame (mm), from the loop thread's last read.
  Vec3d falcon_position() const noexcept;

 private:
  struct Incoming {
    std::array<std::int16_t, 3> encoders{};
    std::uint8_t buttons = 0, homed = 0;
  };
  struct Outgoing {
    std::array<std::int16_t, 3> efforts{};
  };
  std::string setup(libusb_device_handle* handle);  // on_open
  std::string upload(libusb_device_handle* handle);
  bool answers_frames(libusb_device_handle* handle, int tries);
  void on_packet(const std::uint8_t* data, std::size_t size);
  void send_frame(const std::array<std::int16_t, 3>& efforts, std::int64_t now);

  Options options_;
  std::shared_ptr<usb::UsbContext> context_;
  std::unique_ptr<usb::UsbLink> link_;
  LatestBox<Incoming> incoming_;
  LatestBox<Outgoing> commands_;
  bool active_ = false;
  bool report_at_stop_ = false;
  std::int64_t activated_ns_ = 0;

  // Event thread.
  usb::falcon::FrameParser parser_;
  bool awaiting_ = false;
  std::int64_t sent_ns_ = 0, last_command_ns_ = 0;
  std::uint8_t device_homed_ = 0, device_buttons_ = 0;
  void set_note(std::string note);
  mutable std::mutex note_mutex_;  // setup_note_ (not real time: setup and status_message)
  std::string setup_note_;

  // Loop thread.
  Vec3d falcon_pos_ = falcon::kWorkspaceCentre;
  bool clutch_ = false, recentre_ = false;
  bool held_off_ = false;  // the last frame said not homed, or clutch held, or the link went
  Vec3d clutch_offset_{}, frozen_{};
  Vec3d last_device_pos_{};

  std::atomic<bool> homed_{false};
  std::atomic<std::uint64_t> frames_{0}, corrupt_{0}, short_frames_{0}, short_packets_{0},
      host_frames_{0}, zero_frames_{0}, lost_{0}, clamped_{0}, fk_failures_{0}, uploads_{0},
      upload_failures_{0}, already_running_{0}, opens_{0}, recentres_{0};
  std::atomic<std::uint8_t> buttons_{0}, homed_bits_{0};
  std::atomic<std::uint32_t> last_efforts_packed_[3] = {};
  std::atomic<double> pos_[3] = {};
};

// "falcon" / "falcon:INDEX" -> a FalconDevice without firmware (palpd adds it from
// --falcon-firmware). UsageError for a bad index.
std::unique_ptr<Device> make_falcon_device(std::string_view arg);

}  // namespace palp::rt
