// Haptic devices behind one small interface, in the manner of ros2_control's SystemInterface:
// configure -> activate -> (read -> write)* -> deactivate, every call returning a status.
//
//   sim            the built-in palpation path for the scene, played in real time, looping: on
//                  the torso a press, a slide across the ribs and a lift (trajectory_gen's ribs
//                  path); on scenes where that path does not fit, a press-and-hold on the skin
//                  seen from above
//   sim:FILE       a trajectory CSV (t,px,py,pz,qw,qx,qy,qz) replayed at its timestamps, looping
//   replay:FILE    a palpd recording played back tick by tick: the same poses in the same ticks,
//                  and the same zeroed ticks, so the model reproduces the recorded forces bit for
//                  bit (same scene, tool, parameters, profile and rate)
//   remote         the pose comes from a CONTROLLER client over the network (RemoteDevice::submit)
//   usb-haptic[:VID:PID]  a force-feedback device speaking the open haptic protocol over USB
//                  (docs/usb-protocol.md; default 1209:0001), hot-plug safe
//                  (devices/usb_haptic_device.hpp)
//   falcon[:INDEX] a Novint Falcon on libusb: firmware load, homing, delta kinematics, 3-DOF
//                  force (devices/falcon_device.hpp, docs/devices.md)
//   spacemouse[:position|:rate][:VID:PID]  a 3Dconnexion SpaceMouse as a pose source (rate mode
//                  by default); no force output, so clients show the force on screen
//                  (devices/spacemouse_device.hpp)
//
// read() and write() run in the real-time thread: they never allocate, lock, log or throw. A
// device that samples at its own rate answers NoData when it has nothing new (the loop keeps the
// last pose); one that can disappear answers Timeout or Disconnected, and the loop zeroes the
// force and reports the fault (haptic_loop.hpp). A hot-plug device that is not plugged in answers
// Absent: the loop zeroes the force, keeps ticking and reports the device absent (one absent
// period per unplug, not a fault per tick). state() says Present / Absent / Fault for clients.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "model/field_sampler.hpp"
#include "model/force_model.hpp"
#include "model/tool.hpp"
#include "rt/snapshot.hpp"
#include "safety/safety.hpp"
#include "scene/trajectory.hpp"

namespace palp::rt {

enum class DeviceStatus : std::uint8_t {
  Ok,            // a fresh sample / the command was taken
  NoData,        // nothing new yet: keep the last sample
  Timeout,       // the device did not answer in time
  Disconnected,  // the device is gone
  Finished,      // a played-back source reached its end
  Error,         // anything else; last_error() says what
  Absent,        // a hot-plug device that is not plugged in (not a fault): zero force
};
const char* to_string(DeviceStatus status);

// DeviceState (base/device_state.hpp, through snapshot.hpp): Present / Absent / Fault, as
// clients see it; its names are base's.

struct DeviceSample {
  Pose pose{};
  // Bits (LoopFault) the loop must treat as if they had happened this tick: a replay reproduces
  // the recorded zero-force ticks with them. 0 for live devices.
  std::uint32_t forced_fault = 0;
};

// A framed device link's counters (Stats), for devices that have one (0: none).
struct DeviceLinkCounters {
  std::uint64_t exchanges = 0;      // frames answered
  std::uint64_t corrupt = 0;        // frames dropped as corrupt
  std::uint64_t short_frames = 0;   // frames dropped as cut short
  std::uint64_t lost_replies = 0;   // requests never answered
  std::uint64_t force_limited = 0;  // commands the device could not render whole: its motors'
                                    // limit scaled the force down (direction kept)
};

struct DeviceCommand {
  Vec3d force{};   // N
  Vec3d torque{};  // N·mm
};

// What a device may need at configure time.
struct DeviceConfig {
  double rate_hz = 1000.0;                     // the loop's rate
  std::shared_ptr<const FieldSampler> fields;  // the scene (sim's built-in path)
  Tool tool;                                   // the tool (sim's built-in path: pad offset)
  double timeout_s = 0.25;                     // remote: no pose for this long -> Timeout
  std::optional<Pose> home;  // spacemouse: the home pose (palpd --home); unset: its own default
};

class Device {
 public:
  virtual ~Device() = default;
  virtual std::string_view kind() const noexcept = 0;  // "sim", "replay", "remote", ...

  // Setup (not real time): may allocate and read files. Error + last_error() on failure.
  virtual DeviceStatus configure(const DeviceConfig& config) = 0;
  virtual DeviceStatus activate() = 0;
  // Real time. `now_ns` is the tick's deadline on CLOCK_MONOTONIC.
  virtual DeviceStatus read(std::int64_t now_ns, DeviceSample& sample) noexcept = 0;
  virtual DeviceStatus write(const DeviceCommand& command) noexcept = 0;
  virtual DeviceStatus deactivate() = 0;

  // Real time (an atomic load): the device's state for clients. Devices that cannot vanish are
  // always Present.
  virtual DeviceState state() const noexcept { return DeviceState::Present; }
  // Whether the device renders the force it is written (false: a pose source only).
  virtual bool renders_force() const noexcept { return true; }
  // Whether it pushes on a hand from a frame of its own (usb-haptic, falcon): palpd always
  // limits its force and places it on the patient; the others move in the scene frame.
  virtual bool drives_a_hand() const noexcept { return false; }
  // The device profile its make is known to have ("": none; a hand-driving device then gets
  // the most conservative class).
  virtual std::string_view own_profile() const noexcept { return {}; }
  // Whether it takes a home pose on the patient (palpd --home, --home-clearance) while moving
  // in the scene frame (spacemouse).
  virtual bool takes_home() const noexcept { return false; }
  // Not real time: the device positions it will play, when they are known before it runs (sim:
  // its file or the built-in path for `fields` and `tool`); nullopt when they are not. palpd
  // --map-window MM cuts the maps to their reach.
  virtual std::optional<Trajectory> scripted_path(const FieldSampler& fields,
                                                  const Tool& tool) const {
    (void)fields;
    (void)tool;
    return std::nullopt;
  }
  // Real time (atomic loads): what the device itself declares about its force, stiffness and
  // damping (0: not declared). The loop's limits are lowered to these, never raised.
  virtual DeclaredLimits declared_limits() const noexcept { return {}; }
  double declared_max_force_N() const noexcept { return declared_limits().max_force_N; }
  // Not real time: the device's last event or error, for people ("" when nothing to say).
  virtual std::string status_message() const { return {}; }
  // Any thread (atomic loads): the link's counters, for Stats.
  virtual DeviceLinkCounters link_counters() const noexcept { return {}; }
  // Real time (an atomic load): the buttons held now, bit i = button i (0: none, or a device
  // without buttons). The loop puts them in every snapshot (Snapshot::buttons); bit 0
  // (rt::kMarkButton) marks a training task's spot.
  virtual std::uint32_t buttons() const noexcept { return 0; }

  const std::string& last_error() const { return error_; }

 protected:
  DeviceStatus fail(std::string message) {
    error_ = std::move(message);
    return DeviceStatus::Error;
  }
  std::string error_;
};

// Plays a trajectory in real time, looping (sim, sim:FILE).
class SimDevice final : public Device {
 public:
  // Empty trajectory: the built-in path, made at configure() from the scene and tool.
  explicit SimDevice(Trajectory trajectory = {});
  std::string_view kind() const noexcept override { return "sim"; }
  DeviceStatus configure(const DeviceConfig& config) override;
  DeviceStatus activate() override;
  DeviceStatus read(std::int64_t now_ns, DeviceSample& sample) noexcept override;
  DeviceStatus write(const DeviceCommand& command) noexcept override;
  DeviceStatus deactivate() override;
  std::optional<Trajectory> scripted_path(const FieldSampler& fields,
                                          const Tool& tool) const override;

  const Trajectory& trajectory() const { return trajectory_; }
  double period_s() const { return period_s_; }  // one loop of the path
  const DeviceCommand& last_command() const { return last_command_; }
  std::uint64_t writes() const { return writes_; }

 private:
  Trajectory trajectory_;
  double period_s_ = 0.0;
  std::int64_t start_ns_ = 0;
  bool started_ = false;
  bool active_ = false;
  std::size_t cursor_ = 0;
  double cursor_lap_ = 0.0;
  DeviceCommand last_command_{};
  std::uint64_t writes_ = 0;
};

// The built-in palpation path of `sim` (see the top of this file), at 1 kHz.
Trajectory builtin_palpation_path(const FieldSampler& fields, const Tool& tool);

// Plays a recording back tick by tick (replay:FILE); Finished after the last record.
class ReplayDevice final : public Device {
 public:
  explicit ReplayDevice(std::vector<TickRecord> records);
  std::string_view kind() const noexcept override { return "replay"; }
  DeviceStatus configure(const DeviceConfig& config) override;
  DeviceStatus activate() override;
  DeviceStatus read(std::int64_t now_ns, DeviceSample& sample) noexcept override;
  DeviceStatus write(const DeviceCommand& command) noexcept override;
  DeviceStatus deactivate() override;

  const std::vector<TickRecord>& records() const { return records_; }
  std::size_t position() const { return next_; }

 private:
  std::vector<TickRecord> records_;
  std::size_t next_ = 0;
  bool active_ = false;
};

// The pose comes from the network: submit() from any one thread (the network thread), read()
// in the loop; a triple buffer in between, so neither side waits.
class RemoteDevice final : public Device {
 public:
  std::string_view kind() const noexcept override { return "remote"; }
  bool renders_force() const noexcept override { return false; }
  DeviceStatus configure(const DeviceConfig& config) override;
  DeviceStatus activate() override;
  // NoData until the first pose and between poses; Absent once the last pose is older than the
  // configured timeout (the controller left or stopped: one absent period, not a fault per tick),
  // until poses come again.
  DeviceStatus read(std::int64_t now_ns, DeviceSample& sample) noexcept override;
  DeviceState state() const noexcept override {
    return absent_.load(std::memory_order_relaxed) ? DeviceState::Absent : DeviceState::Present;
  }
  DeviceStatus write(const DeviceCommand& command) noexcept override;
  DeviceStatus deactivate() override;

  // Network side: a new pose, received at `received_ns` (CLOCK_MONOTONIC).
  void submit(const Pose& pose, std::int64_t received_ns) noexcept;
  // The last force written by the loop (for sending back to the controller).
  DeviceCommand last_command() noexcept;

 private:
  struct Timed {
    Pose pose{};
    std::int64_t t_ns = 0;
  };
  LatestBox<Timed> box_;
  LatestBox<DeviceCommand> command_box_;
  DeviceCommand command_seen_{};
  Timed last_{};
  bool have_pose_ = false;
  std::atomic<bool> absent_{false};
  std::int64_t timeout_ns_ = 250'000'000;
};

// "sim", "sim:FILE", "replay:FILE", "remote", "usb-haptic[:VID:PID]", "spacemouse...",
// "falcon[:INDEX]" (without firmware: palpd adds it). UsageError for anything
// else, InputError for a file that cannot be read.
std::unique_ptr<Device> make_device(std::string_view spec);

}  // namespace palp::rt
