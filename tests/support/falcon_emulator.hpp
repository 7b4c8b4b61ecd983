// An emulated Novint Falcon for tests, on the umockdev USB emulator (usb_emulator.hpp), written
// from the published protocol and not from palp's: it includes neither server/usb/falcon_protocol
// nor server/devices/falcon_kinematics, so a wrong bit, sign or length in palp cannot pass by being
// shared (falcon_reference_test.cpp checks the includes). Every wire constant below is transcribed
// from libnifalcon (github.com/libnifalcon/libnifalcon, commit f7c727a, BSD-3) with its file and
// line; the mechanism uses the transcription of libnifalcon's Stamper kinematics in
// falcon_reference.hpp.
//
// What it emulates: the FTDI bridge (vendor requests tracked: baud divisor, latency timer, DTR;
// every IN packet headed by two modem-status bytes, one packet each latency-timer period, data or
// not), the DSP bootloader (probe after a DTR reset at 9600 baud, 'A' at the upload rate, every
// firmware byte echoed), Novint's runtime frames once the right firmware is loaded, and a
// simulated delta mechanism: a point mass driven by the motor efforts (F = J^T tau) and by a test
// "hand" (a spring-damper toward a target), its encoders read back through the inverse kinematics,
// with unknown encoder offsets until homed (homing mode on and the leg pulled past its index
// angle, as when the handle is pulled all the way out).
// Everything here is test code: it allocates and locks.
#pragma once

#include <array>
#include <cstdint>
#include <mutex>
#include <optional>
#include <vector>

#include "base/vec.hpp"
#include "support/falcon_reference.hpp"
#include "support/usb_emulator.hpp"

namespace palp::usbemu {

// The Falcon's wire, as libnifalcon (commit f7c727a) has it. CORE: include/falcon/core/
// FalconComm.h; COMM: src/comm/FalconCommLibUSB.cpp; SDK: src/firmware/FalconFirmwareNovintSDK.cpp;
// FW: include/falcon/core/FalconFirmware.h; GRIP: include/falcon/grip/FalconGripFourButton.h.
namespace nif {
inline constexpr std::uint16_t kVendorId = 0x0403;   // CORE:262
inline constexpr std::uint16_t kProductId = 0xCB48;  // CORE:263
inline constexpr std::uint8_t kBulkOut = 0x02;       // COMM:317, COMM:358
inline constexpr std::uint8_t kBulkIn = 0x81;        // COMM:336, COMM:477
inline constexpr std::size_t kUsbPacket = 64;        // COMM:613-614 (reads of 64)
// FTDI vendor requests (COMM:23-33, "taken from libftdi"), all bmRequestType 0x40 (COMM:29)
inline constexpr std::uint8_t kVendorOut = 0x40;
inline constexpr std::uint8_t kSioReset = 0, kSioModemCtrl = 1, kSioSetFlowCtrl = 2,
                              kSioSetBaudRate = 3, kSioSetData = 4;
inline constexpr std::uint8_t kSioSetLatency = 0x09;        // COMM:409, COMM:560
inline constexpr std::uint16_t kPurgeRx = 1, kPurgeTx = 2;  // COMM:32-33
inline constexpr std::uint16_t kDtrHigh = 1 | (0x1 << 8);   // COMM:52-53
inline constexpr std::uint16_t kDtrLow = 0 | (0x1 << 8);    // COMM:54
inline constexpr std::uint16_t kBaud9600 = 0x4138;          // COMM:423-424
inline constexpr std::uint16_t kBaudUpload = 0x15;          // COMM:505, COMM:515
inline constexpr std::uint16_t kBaudRuntime = 0x2;          // COMM:565
// The bootloader's check (COMM:371-373): the host sends 0a 43 0d, the bootloader answers
// 0a 44 2c 0d (some hosts see a leading 00, COMM:483-492); then 'A' is echoed (COMM:521-538).
inline constexpr std::array<std::uint8_t, 3> kBootProbe = {0x0a, 0x43, 0x0d};
inline constexpr std::array<std::uint8_t, 4> kBootReply = {0x0a, 0x44, 0x2c, 0x0d};
inline constexpr std::uint8_t kBootEnter = 0x41;
// Every IN packet starts with two FTDI modem-status bytes the host skips (COMM:280-281, 341-343).
inline constexpr std::size_t kModemStatusBytes = 2;
// Runtime frames: 16 bytes '<' .. '>' (SDK:43, SDK:82-83); bytes 1-12 three 16-bit values as
// nibbles, least significant first, each + 0x41 (SDK:51-55, SDK:84-91, SDK:94-97); host byte 13
// the LED bits | homing bit (SDK:92-93); device byte 13: grip nibble (SDK:62), homing status in
// bits 4-6 (SDK:61).
inline constexpr std::size_t kFrameBytes = 16;
inline constexpr std::uint8_t kFrameOpen = '<', kFrameClose = '>', kNibbleOffset = 0x41;
inline constexpr std::uint8_t kHomingBit = 0x01;                               // SDK:93
inline constexpr std::uint8_t kGreenLed = 0x2, kBlueLed = 0x4, kRedLed = 0x8;  // FW:68-70
inline constexpr std::uint8_t kPlusButton = 0x1, kForwardButton = 0x2, kCenterButton = 0x4,
                              kMinusButton = 0x8;           // GRIP:40-43
inline constexpr std::uint8_t kAllHomed = 0x1 | 0x2 | 0x4;  // FW:75-77
}  // namespace nif

class EmulatedFalcon {
 public:
  EmulatedFalcon(UsbTestbed& testbed, std::vector<std::uint8_t> firmware);
  ~EmulatedFalcon();

  void power_on();  // plug in (firmware not loaded, not homed) and start the bridge's IN stream
  void unplug();    // power and USB gone: firmware and homing lost

  // The hand on the handle: a spring (N/mm) and damper (N s/mm) toward `target` (Falcon frame,
  // mm). release_hand(): nobody holds it (only the motors and friction act).
  void hold(const Vec3d& target, double k_N_per_mm = 1.0, double c_N_s_per_mm = 0.01);
  void release_hand();
  void set_buttons(std::uint8_t buttons);  // nif::k*Button bits
  // Fault injection: the next `n` replies are corrupted / cut short / dropped; raw serial bytes
  // inserted before the next reply; `n` upload attempts get one echo byte wrong.
  void corrupt_replies(int n);
  void cut_replies(int n);
  void drop_replies(int n);
  void inject(std::vector<std::uint8_t> bytes);
  void corrupt_echo_attempts(int n);
  // The bootloader's answer to the first probe comes only when the host probes again (later
  // than it waited: a loaded machine), and the answer to that second probe after the host has
  // read the first: one answer too many waits when the host goes on to the 'A'.
  void delay_first_probe_reply();
  // The firmware is already running (e.g. palpd restarted without a power cycle).
  void set_running();

  struct Snapshot {
    bool running = false;
    std::uint8_t homed = 0;
    Vec3d position{};     // Falcon frame, mm
    Vec3d motor_force{};  // N, what the motors push on the handle now (J^T tau)
    Vec3d hand_force{};   // N, what the hand pushes
    std::array<std::int16_t, 3> efforts{};
    std::uint8_t control = 0;     // the last host frame's byte 13 less 0x41
    std::uint64_t frames_in = 0;  // host frames taken
    std::uint64_t replies = 0;    // device frames sent
    std::uint64_t probes = 0;     // bootloader probes answered
    std::uint64_t loads = 0;      // firmware images received whole
    std::uint64_t echoed = 0;     // firmware bytes echoed
    std::uint64_t dtr_resets = 0;
    std::uint64_t nonzero_while_unhomed = 0;  // host frames with effort before homing
    // host frames with a motor beyond libnifalcon's documented cap (falcon_reference.hpp,
    // kDocumentedEffortCap); what the firmware would do with them is unpublished
    std::uint64_t over_cap = 0;
    std::uint64_t bad_frames = 0;  // 16 bytes '<' .. '>' with a byte out of its range
  };
  Snapshot snapshot();

  EmulatedUsbDevice& usb() { return usb_; }

 private:
  enum class Mode { Boot, Probed, Loading, Running, Crashed };
  ControlReply control(const ControlRequest& r);
  void out(const std::vector<std::uint8_t>& packet);
  void boot_out(const std::vector<std::uint8_t>& packet);  // bootloader and upload (mutex held)
  void take_host_frames();                                 // runtime (mutex held)
  std::optional<std::vector<std::uint8_t>> tick(std::int64_t device_time_ns);
  void home_legs();        // (mutex held)
  void step(double dt_s);  // the mechanism (mutex held)
  void reply();            // one device frame (mutex held)
  void reset_power();      // (mutex held)

  std::vector<std::uint8_t> firmware_;
  EmulatedUsbDevice usb_;
  std::mutex mutex_;
  Mode mode_ = Mode::Boot;
  std::uint16_t baud_ = 0, latency_ = 16;
  bool dtr_ = false, dtr_reset_ = false;
  std::vector<std::uint8_t> tx_;       // serial bytes waiting for the IN endpoint
  std::vector<std::uint8_t> boot_rx_;  // bootloader input
  std::vector<std::uint8_t> image_;    // firmware received
  int echo_faults_ = 0;
  bool echo_fault_this_load_ = false;
  bool delay_probe_reply_ = false, probe_reply_held_ = false, probe_reply_pending_ = false;
  std::vector<std::uint8_t> host_rx_;
  std::int64_t last_tick_ns_ = -1, last_in_ns_ = 0;
  // mechanism
  Vec3d p_{0, 0, 110}, v_{};
  std::array<std::int16_t, 3> efforts_{};
  std::uint8_t control_ = 0, buttons_ = 0, homed_ = 0;
  std::array<double, 3> offsets_{};  // encoder offsets until homed
  bool hand_ = false;
  Vec3d target_{};
  double k_ = 1.0, c_ = 0.01;
  Vec3d motor_force_{}, hand_force_{};
  int corrupt_ = 0, cut_ = 0, drop_ = 0;
  std::vector<std::uint8_t> inject_;
  Snapshot counters_;
};

}  // namespace palp::usbemu
