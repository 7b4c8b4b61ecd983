// palpview --controller: mouse and keyboard events -> the device pose sent to palpd's `remote`
// device, and the commands (SetTool, SetPaused) they ask for. Pure: no window, no network; the
// window (view_window.cpp) translates GLFW events into the calls below, main sends pose() every
// frame and forwards take_tool_request() / take_pause_request().
//
// Data flow: event + the camera's screen axes (scene frame) -> pose update -> pose().
// Mapping (all in the scene frame, mm; see docs/palpview.md):
//   left drag             slide: the device point moves in the screen plane,
//                         dx * right - dy * up (window y grows downward) times drag_mm_per_pixel
//   shift + left drag     rotate the tool about its device point: dx about the camera's up axis,
//                         dy about its right axis, drag_rad_per_pixel each
//   scroll (+ = away)     press: along the tool's -z axis (into the skin) press_mm_per_notch per
//                         notch; W / S do the same by key_step_mm
//   arrow keys            slide by key_step_mm along the camera's right / up axes
//   Q / E, R / F, Z / C   rotate by key_rotate_rad about the tool's own z, x and y axes
//   1 / 2 / 3             SetTool finger:37 / twofinger:19 / probe:9x3
//   space                 pause / resume the haptic loop (SetPaused)
//   backspace             back to the start pose
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "base/vec.hpp"
#include "model/force_model.hpp"

namespace palp::view {

enum class MouseButton { Left, Right, Middle };

enum class InputKey {
  SlideLeft,
  SlideRight,
  SlideUp,
  SlideDown,  // arrow keys
  PressIn,
  PressOut,  // W, S
  YawLeft,
  YawRight,  // Q, E: about tool z
  PitchUp,
  PitchDown,  // R, F: about tool x
  RollLeft,
  RollRight,  // Z, C: about tool y
  ToolFinger,
  ToolTwoFinger,
  ToolProbe,  // 1, 2, 3
  Pause,      // space
  ResetPose,  // backspace
};

// The camera's axes in the scene frame (unit vectors): screen right and up.
struct CameraAxes {
  Vec3d right{1, 0, 0};
  Vec3d up{0, 0, 1};
};

struct ControllerSettings {
  double drag_mm_per_pixel = 0.25;
  double drag_rad_per_pixel = 0.005;
  double press_mm_per_notch = 1.0;
  double key_step_mm = 2.0;
  double key_rotate_rad = 0.0872664625997164788;  // 5 degrees
};

inline constexpr const char* kFingerTool = "finger:37";
inline constexpr const char* kTwoFingerTool = "twofinger:19";
inline constexpr const char* kProbeTool = "probe:9x3";

class ControllerInput {
 public:
  explicit ControllerInput(Pose start = {}, ControllerSettings settings = {});

  // Mouse button pressed or released at window position (x, y) (pixels, y down).
  void button(MouseButton button, bool pressed, double x, double y, bool shift);
  // Cursor moved; returns true when it changed the pose (a left drag is in progress).
  bool cursor(double x, double y, const CameraAxes& camera);
  // Scroll by `notches` (+: press into the skin). Changes the pose.
  void scroll(double notches);
  // A key; returns true when it changed the pose.
  bool key(InputKey key, const CameraAxes& camera);

  const Pose& pose() const { return pose_; }
  const Pose& start_pose() const { return start_; }
  // New start pose (and pose): after the scene arrived or the server restarted.
  void reset(const Pose& start);
  bool dragging() const { return dragging_; }

  // The tool asked for since the last call ("finger:37", ...), once.
  std::optional<std::string> take_tool_request();
  // The paused state asked for since the last call (space toggles), once.
  std::optional<bool> take_pause_request();

 private:
  void rotate_scene(const Vec3d& axis, double angle);  // about a scene-frame axis
  void rotate_tool(const Vec3d& axis, double angle);   // about a tool-frame axis

  ControllerSettings settings_;
  Pose start_, pose_;
  bool dragging_ = false, rotating_ = false;
  double last_x_ = 0, last_y_ = 0;
  bool paused_ = false;
  std::optional<std::string> tool_request_;
  std::optional<bool> pause_request_;
};

// A start pose for a volume of `dims` at `spacing` with the skin map `d_surf` (mm, positive
// inside, i fastest): the tool points +y (anterior -> posterior: tool -z maps to scene +y) above
// the body's front at the centre of the (i, k) plane, its pads `clearance_mm` in front of the
// first voxel inside the body along that line (the grid's front face when none is). `origin`:
// where voxel (0, 0, 0) lies (scene mm; a cropped volume).
Pose initial_pose(const std::array<std::int64_t, 3>& dims, const std::array<double, 3>& spacing,
                  std::span<const float> d_surf, double clearance_mm = 20.0,
                  const std::array<double, 3>& origin = {});

}  // namespace palp::view
