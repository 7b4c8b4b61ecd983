// An emulated Novint Falcon for tests, on the umockdev USB emulator (usb_emulator.hpp): the FTDI
// bridge (vendor requests tracked: baud divisor, latency timer, DTR; every IN packet headed by two
// status bytes, one packet each latency-timer period, data or not), the DSP bootloader (probe
// after a DTR reset at 9600 baud, 'A' at the upload rate, every firmware byte echoed), Novint's
// runtime frames once the right firmware is loaded, and a simulated delta mechanism: a point
// mass on the published geometry (model/falcon_kinematics.hpp) driven by the motor efforts and
// by a test "hand" (a spring-damper toward a target), its encoders read back through inverse
// kinematics, with unknown encoder offsets until homed (homing mode on and the leg pulled past
// its index angle, as when the handle is pulled all the way out).
// Everything here is test code: it allocates and locks.
#pragma once

#include <array>
#include <cstdint>
#include <mutex>
#include <vector>

#include "base/vec.hpp"
#include "support/usb_emulator.hpp"
#include "usb/falcon_protocol.hpp"

namespace palp::usbemu {

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
  void set_buttons(std::uint8_t buttons);
  // Fault injection: the next `n` replies are corrupted / cut short / dropped; raw serial bytes
  // inserted before the next reply; `n` upload attempts get one echo byte wrong.
  void corrupt_replies(int n);
  void cut_replies(int n);
  void drop_replies(int n);
  void inject(std::vector<std::uint8_t> bytes);
  void corrupt_echo_attempts(int n);
  // The firmware is already running (e.g. palpd restarted without a power cycle).
  void set_running();

  struct Snapshot {
    bool running = false;
    std::uint8_t homed = 0;
    Vec3d position{};     // Falcon frame, mm
    Vec3d motor_force{};  // N, what the motors push on the handle now (J^T tau)
    Vec3d hand_force{};   // N, what the hand pushes
    std::array<std::int16_t, 3> efforts{};
    std::uint8_t control = 0;
    std::uint64_t frames_in = 0;  // host frames taken
    std::uint64_t replies = 0;    // device frames sent
    std::uint64_t probes = 0;     // bootloader probes answered
    std::uint64_t loads = 0;      // firmware images received whole
    std::uint64_t echoed = 0;     // firmware bytes echoed
    std::uint64_t dtr_resets = 0;
    std::uint64_t nonzero_while_unhomed = 0;  // host frames with effort before homing
  };
  Snapshot snapshot();

  EmulatedUsbDevice& usb() { return usb_; }

 private:
  enum class Mode { Boot, Probed, Loading, Running, Crashed };
  ControlReply control(const ControlRequest& r);
  void out(const std::vector<std::uint8_t>& packet);
  std::optional<std::vector<std::uint8_t>> tick(std::int64_t device_time_ns);
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
  usb::falcon::FrameParser host_parser_;  // parses host frames (same framing, other direction)
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
