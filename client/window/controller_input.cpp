// Input events -> device pose and commands for palpview --controller (see controller_input.hpp
// for the mapping). Pure arithmetic on the pose; no window or network.
#include "window/controller_input.hpp"

#include <cmath>
#include <numbers>

#include "model/tool.hpp"

namespace palp::view {

ControllerInput::ControllerInput(Pose start, ControllerSettings settings)
    : settings_(settings), start_(start), pose_(start) {}

void ControllerInput::reset(const Pose& start) {
  start_ = start;
  pose_ = start;
  dragging_ = rotating_ = false;
}

void ControllerInput::button(MouseButton button, bool pressed, double x, double y, bool shift) {
  if (button != MouseButton::Left) return;
  dragging_ = pressed;
  rotating_ = pressed && shift;
  last_x_ = x;
  last_y_ = y;
}

bool ControllerInput::cursor(double x, double y, const CameraAxes& camera) {
  if (!dragging_) return false;
  const double dx = x - last_x_, dy = y - last_y_;
  last_x_ = x;
  last_y_ = y;
  if (dx == 0 && dy == 0) return false;
  if (rotating_) {
    if (dx != 0) rotate_scene(camera.up, dx * settings_.drag_rad_per_pixel);
    if (dy != 0) rotate_scene(camera.right, dy * settings_.drag_rad_per_pixel);
  } else {
    pose_.position += (dx * camera.right - dy * camera.up) * settings_.drag_mm_per_pixel;
  }
  return true;
}

void ControllerInput::scroll(double notches) {
  const Vec3d into_skin = rotate(pose_.orientation, Vec3d{0, 0, -1});
  pose_.position += into_skin * (notches * settings_.press_mm_per_notch);
}

bool ControllerInput::key(InputKey key, const CameraAxes& camera) {
  const double step = settings_.key_step_mm, angle = settings_.key_rotate_rad;
  const Vec3d into_skin = rotate(pose_.orientation, Vec3d{0, 0, -1});
  switch (key) {
    case InputKey::SlideLeft:
      pose_.position -= camera.right * step;
      return true;
    case InputKey::SlideRight:
      pose_.position += camera.right * step;
      return true;
    case InputKey::SlideUp:
      pose_.position += camera.up * step;
      return true;
    case InputKey::SlideDown:
      pose_.position -= camera.up * step;
      return true;
    case InputKey::PressIn:
      pose_.position += into_skin * step;
      return true;
    case InputKey::PressOut:
      pose_.position -= into_skin * step;
      return true;
    case InputKey::YawLeft:
      rotate_tool({0, 0, 1}, angle);
      return true;
    case InputKey::YawRight:
      rotate_tool({0, 0, 1}, -angle);
      return true;
    case InputKey::PitchUp:
      rotate_tool({1, 0, 0}, angle);
      return true;
    case InputKey::PitchDown:
      rotate_tool({1, 0, 0}, -angle);
      return true;
    case InputKey::RollLeft:
      rotate_tool({0, 1, 0}, angle);
      return true;
    case InputKey::RollRight:
      rotate_tool({0, 1, 0}, -angle);
      return true;
    case InputKey::ToolFinger:
      tool_request_ = kFingerTool;
      return false;
    case InputKey::ToolTwoFinger:
      tool_request_ = kTwoFingerTool;
      return false;
    case InputKey::ToolProbe:
      tool_request_ = kProbeTool;
      return false;
    case InputKey::Pause:
      paused_ = !paused_;
      pause_request_ = paused_;
      return false;
    case InputKey::ResetPose:
      pose_ = start_;
      return true;
  }
  return false;
}

std::optional<std::string> ControllerInput::take_tool_request() {
  auto out = tool_request_;
  tool_request_.reset();
  return out;
}

std::optional<bool> ControllerInput::take_pause_request() {
  auto out = pause_request_;
  pause_request_.reset();
  return out;
}

void ControllerInput::rotate_scene(const Vec3d& axis, double angle) {
  pose_.orientation = normalized(multiply(axis_angle(axis, angle), pose_.orientation));
}

void ControllerInput::rotate_tool(const Vec3d& axis, double angle) {
  pose_.orientation = normalized(multiply(pose_.orientation, axis_angle(axis, angle)));
}

Pose initial_pose(const std::array<std::int64_t, 3>& dims, const std::array<double, 3>& spacing,
                  std::span<const float> d_surf, double clearance_mm,
                  const std::array<double, 3>& origin) {
  const std::int64_t ci = dims[0] / 2, ck = dims[2] / 2;
  std::int64_t front_j = 0;
  const bool sized = dims[0] > 0 && dims[1] > 0 && dims[2] > 0 &&
                     static_cast<std::int64_t>(d_surf.size()) == dims[0] * dims[1] * dims[2];
  if (sized) {
    for (std::int64_t j = 0; j < dims[1]; ++j) {
      if (d_surf[static_cast<std::size_t>((ck * dims[1] + j) * dims[0] + ci)] > 0.0f) {
        front_j = j;
        break;
      }
    }
  }
  Pose pose;
  // Tool -z (the pads' side) points into the body: +y, a quarter turn about x.
  pose.orientation = axis_angle({1, 0, 0}, 0.5 * std::numbers::pi);
  pose.position = {
      origin[0] + static_cast<double>(ci) * spacing[0],
      origin[1] + static_cast<double>(front_j) * spacing[1] + kFingerPadZ - clearance_mm,
      origin[2] + static_cast<double>(ck) * spacing[2]};
  return pose;
}

}  // namespace palp::view
