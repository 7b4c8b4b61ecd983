// `--device spacemouse[:position|:rate][:VID:PID]`: a 3Dconnexion SpaceMouse (USB HID, 6-DOF
// input, no force output) as a pose source, read through libusb and hot-plug safe, so a station
// without a haptic device still palpates; clients show the force it cannot render
// (renders_force() is false, SceneInfo.device_renders_force).
//
// Data flow:
//   HID input report (interrupt IN 0x81, ~60-125 Hz while the cap moves) ─► UsbLink (libusb
//   event thread) ─► parse_report: report 1 translation (or all six axes), 2 rotation, 3 buttons;
//   short / malformed / unknown reports counted and ignored ─► the newest six axes in a LatestBox,
//   button presses as counters ─► read() in the loop: PoseMapper turns the deflection into a pose
//   around the home pose (rate: integrate, position: offset), inside the workspace box.
//   write() in the loop: the force is counted and dropped (nothing to render it).
// Unplugged: the link says Absent at once and read() answers DeviceStatus::Absent (the loop zeroes
// the force, keeps ticking, clients see DEVICE_ABSENT); replugged: streaming again, the pose goes
// on from where it was, the deflection starts from rest.
// read() and write() only touch atomics and the LatestBox: no allocation, lock, log or throw.
//
// Axes (docs/usb-protocol.md, "SpaceMouse"): the HID frame is x right, y toward the user, z down
// (pushing the cap down is +z). palp's "user frame" is x right, y away from the user, z up, i.e.
// (x, -y, -z) for translations and rotations alike (a proper rotation, 180° about x). The user
// frame is the home pose's tool frame: tool +z is the skin's outward normal at home and tool +y
// the built-in path's slide direction, so pushing the cap down presses into the skin, pushing it
// away slides along the path, and twisting turns the finger about the normal. Translations move
// the tool in the home frame; rotations turn it about its own axes (rate) or set its orientation
// relative to home (position).
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "devices/device.hpp"
#include "rt/snapshot.hpp"
#include "usb/usb_context.hpp"

namespace palp::rt {

namespace spacemouse {

// Every 3Dconnexion device palp knows (deploy/udev/70-palp.rules lists the same).
inline constexpr std::array<usb::UsbId, 18> kKnownIds{{
    {0x046d, 0xc603},
    {0x046d, 0xc605},
    {0x046d, 0xc606},
    {0x046d, 0xc621},
    {0x046d, 0xc623},
    {0x046d, 0xc625},
    {0x046d, 0xc626},
    {0x046d, 0xc627},
    {0x046d, 0xc628},
    {0x046d, 0xc629},
    {0x046d, 0xc62b},
    {0x256f, 0xc62e},
    {0x256f, 0xc62f},
    {0x256f, 0xc631},
    {0x256f, 0xc632},
    {0x256f, 0xc633},
    {0x256f, 0xc635},
    {0x256f, 0xc652},
}};
bool is_known(usb::UsbId id) noexcept;

inline constexpr std::uint8_t kEndpointIn = 0x81;
inline constexpr int kInterface = 0;
// Axis values beyond this many counts are not a SpaceMouse talking (nominal ±350, some ±512):
// the report is malformed.
inline constexpr int kMaxPlausibleCounts = 2048;

// The raw deflection: tx, ty, tz, rx, ry, rz in HID counts (HID frame, see the top of the file).
using Axes = std::array<std::int16_t, 6>;

enum class ReportKind : std::uint8_t {
  Translation,  // report 1, 6 bytes of payload: axes 0-2
  SixAxes,      // report 1, 12 bytes of payload or more: axes 0-5 (newer devices)
  Rotation,     // report 2: axes 3-5
  Buttons,      // report 3: a bitmask, 1-4 bytes
  Short,        // empty, or shorter than its report ID needs
  Malformed,    // a length no layout has (report 1 with 7-11 payload bytes), or implausible values
  Unknown,      // another report ID (battery, LEDs, ...)
};
const char* to_string(ReportKind kind);

// Parses one input report; on Translation / SixAxes / Rotation updates only the axes the report
// carries, on Buttons sets `buttons`; otherwise leaves both alone.
ReportKind parse_report(const std::uint8_t* data, std::size_t size, Axes& axes,
                        std::uint32_t& buttons) noexcept;

enum class Mode : std::uint8_t { Rate, Position };
const char* to_string(Mode mode);

struct MapperSettings {
  Mode mode = Mode::Rate;
  double deadband_counts = 15.0;     // |counts| at or below this: 0; above: counts minus this
  double full_scale_counts = 350.0;  // counts saturate here (devices that send ±512 saturate)
  double rate_mm_s_per_count = 0.1;  // rate: 33.5 mm/s at full deflection
  double rate_deg_s_per_count = 0.1;
  double position_mm_per_count = 0.05;  // position: ±16.75 mm at full deflection
  double position_deg_per_count = 0.05;
  bool rotation = true;  // false: the tool keeps the home orientation
  // The workspace box, in the home frame (mm from home): |x|, |y| <= lateral; z in [-below, above].
  double box_lateral_mm = 60.0;
  double box_below_mm = 40.0;  // how far the device point may go below home (into the body)
  double box_above_mm = 40.0;
  double max_tilt_deg = 45.0;  // the orientation stays within this angle of home
};
void validate(const MapperSettings& settings);  // UsageError naming the setting

// Deflection -> pose around a home pose. Pure and allocation-free; the device runs it in the loop
// thread, tests run it directly.
class PoseMapper {
 public:
  explicit PoseMapper(MapperSettings settings = {}, Pose home = {});

  void set_home(const Pose& home);  // also goes home
  // Back to the home pose (rate mode), press lock off.
  void go_home() noexcept;
  // Press lock: the press coordinate (home-frame z) holds its value while on, so the user slides
  // at a constant depth with the cap let go vertically.
  void toggle_press_lock() noexcept;
  bool press_lock() const noexcept { return press_lock_; }

  // One step: `axes` (HID counts) held for `dt_s` (rate mode; position mode ignores dt).
  const Pose& update(const Axes& axes, double dt_s) noexcept;
  const Pose& pose() const noexcept { return pose_; }
  const Pose& home() const noexcept { return home_; }
  Vec3d offset() const noexcept { return offset_; }  // home frame, mm
  const MapperSettings& settings() const noexcept { return settings_; }

  // A count after deadband and saturation (signed, 0 inside the deadband).
  double shaped(double counts) const noexcept;

 private:
  void compose() noexcept;
  MapperSettings settings_;
  Pose home_{};
  Vec3d offset_{};
  Quat relative_{};  // orientation relative to home (tool frame at home)
  bool press_lock_ = false;
  double locked_z_ = 0.0;
  Pose pose_{};
};

// The home pose for a scene: the start of sim's built-in path (builtin_palpation_path: above the
// torso's chest wall, or above the top of any other body), lifted `lift_mm` along its tool +z.
Pose home_pose(const FieldSampler& fields, const Tool& tool, double lift_mm);

}  // namespace spacemouse

class SpaceMouseDevice final : public Device {
 public:
  struct Options {
    spacemouse::MapperSettings mapper;
    std::vector<usb::UsbId> ids;  // empty: every known 3Dconnexion device (kKnownIds)
    std::optional<Pose> home;     // unset: from the scene at configure() (home_pose)
    double home_lift_mm = 10.0;   // above the built-in path's start
    double max_step_s = 0.05;     // rate mode: a longer gap between reads integrates this much
    std::shared_ptr<usb::UsbContext> context;  // null: activate() makes one
  };
  explicit SpaceMouseDevice(Options options);
  ~SpaceMouseDevice() override;

  std::string_view kind() const noexcept override { return "spacemouse"; }
  bool takes_home() const noexcept override { return true; }
  bool renders_force() const noexcept override { return false; }
  DeviceStatus configure(const DeviceConfig& config) override;
  DeviceStatus activate() override;  // Ok also when no SpaceMouse is plugged in yet
  // Absent while none is present; otherwise Ok every tick with the mapped pose (the device sends
  // reports only while the cap moves: the last deflection holds between them).
  DeviceStatus read(std::int64_t now_ns, DeviceSample& sample) noexcept override;
  DeviceStatus write(const DeviceCommand& command) noexcept override;  // counted, not rendered
  DeviceStatus deactivate() override;
  DeviceState state() const noexcept override;
  std::string status_message() const override;

  struct Counters {
    std::uint64_t reports = 0;        // axis and button reports used
    std::uint64_t short_reports = 0;  // ignored
    std::uint64_t malformed = 0;      // ignored
    std::uint64_t unknown = 0;        // other report IDs, ignored
    std::uint64_t other_device = 0;   // from a second SpaceMouse while one is in use, ignored
    std::uint64_t home_presses = 0;   // left button (button 1) presses
    std::uint64_t lock_presses = 0;   // right button (button 2) presses
    std::uint64_t writes = 0;         // forces written (not rendered)
    std::uint64_t opens = 0;          // devices opened (1 + replugs)
    std::uint32_t buttons = 0;        // the newest button mask
  };
  Counters counters() const noexcept;
  const Options& options() const { return options_; }
  // The newest force the loop wrote (what the screen shows), read from any thread.
  Vec3d last_force() const noexcept;

 private:
  void on_report(std::size_t link_index, const std::uint8_t* data, std::size_t size);
  void on_close(std::size_t link_index);
  std::string describe_ids() const;

  Options options_;
  std::shared_ptr<usb::UsbContext> context_;
  std::vector<std::unique_ptr<usb::UsbLink>> links_;
  bool active_ = false;

  // Event thread.
  spacemouse::Axes axes_{};
  std::uint32_t buttons_ = 0;
  // The link whose reports are used (the first to report); -1: none. Written on the event thread.
  std::atomic<int> owner_{-1};

  // Event thread -> loop.
  LatestBox<spacemouse::Axes> incoming_;
  std::atomic<std::uint64_t> reports_{0}, short_{0}, malformed_{0}, unknown_{0}, other_{0},
      home_presses_{0}, lock_presses_{0};
  std::atomic<std::uint32_t> button_mask_{0};

  // Loop thread.
  spacemouse::PoseMapper mapper_;
  spacemouse::Axes current_{};
  std::uint64_t home_seen_ = 0, lock_seen_ = 0;
  std::int64_t last_read_ns_ = 0;
  bool was_present_ = false;

  // Loop -> anyone.
  std::atomic<std::uint64_t> writes_{0};
  std::atomic<double> force_x_{0.0}, force_y_{0.0}, force_z_{0.0};
};

// make_device's `spacemouse` spec; `arg` is what follows "spacemouse:" ("" for none):
// "", "rate", "position", "VID:PID", "rate:VID:PID", "position:VID:PID". UsageError otherwise.
std::unique_ptr<Device> make_spacemouse_device(std::string_view arg);

}  // namespace palp::rt
