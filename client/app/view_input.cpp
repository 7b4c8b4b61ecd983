// palpview's input mapping (see the header; the keys are app/key_bindings).
#include "app/view_input.hpp"

#include <GLFW/glfw3.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "app/key_bindings.hpp"
#include "render/patient_view.hpp"

namespace palp::view {
namespace {

// The mouse's drag state, shared by the callbacks.
struct Drag {
  bool orbiting = false, windowing = false;
  double last_x = 0, last_y = 0;
};

void apply_view_key(ViewKey key, ViewWindow& window, RenderScene& scene, bool controller_mode,
                    InputRequests& requests) {
  switch (key) {
    case ViewKey::Close:
      window.request_close();
      return;
    case ViewKey::NextPreset:
      scene.set_preset(
          static_cast<PresetId>((static_cast<int>(scene.preset()) + 1) % kPresetCount));
      return;
    case ViewKey::LevelDown:
      scene.adjust_window(-20.0, 1.0);
      return;
    case ViewKey::LevelUp:
      scene.adjust_window(20.0, 1.0);
      return;
    case ViewKey::Narrower:
      scene.adjust_window(0.0, 1.0 / 1.2);
      return;
    case ViewKey::Wider:
      scene.adjust_window(0.0, 1.2);
      return;
    case ViewKey::ResetCamera:
      scene.reset_camera();
      return;
    case ViewKey::Recentre:
      if (controller_mode) requests.recentre = true;  // sent from the frame loop
      return;
    case ViewKey::ToggleRecording:
      if (controller_mode) requests.record_toggle = true;  // sent from the frame loop
      return;
    case ViewKey::PulseSlower:
    case ViewKey::PulseFaster:
      if (controller_mode) requests.pulse.steps += key == ViewKey::PulseFaster ? 1 : -1;
      return;
    case ViewKey::TaskMark:
      if (controller_mode) requests.task_mark = true;  // sent from the frame loop
      return;
    case ViewKey::ToggleLandmarks:
      scene.set_landmarks_wanted(!scene.landmarks_wanted());
      return;
    case ViewKey::PulseToggle:
      if (controller_mode) requests.pulse.toggle = !requests.pulse.toggle;
      return;
    case ViewKey::NextView: {
      const auto at = std::find(kViewCycle.begin(), kViewCycle.end(), scene.view());
      scene.set_view(at == kViewCycle.end() || at + 1 == kViewCycle.end() ? kViewCycle[0]
                                                                          : *(at + 1));
      return;
    }
  }
}

}  // namespace

ViewEvents view_events(ViewWindow& window, RenderScene& scene, ControllerInput& controller,
                       bool controller_mode, InputRequests& requests) {
  auto drag = std::make_shared<Drag>();
  ViewEvents events;
  events.mouse_button = [&controller, controller_mode, drag](int button, bool pressed, double x,
                                                             double y, int mods) {
    drag->last_x = x, drag->last_y = y;
    if (button == GLFW_MOUSE_BUTTON_LEFT && controller_mode) {
      controller.button(MouseButton::Left, pressed, x, y, (mods & GLFW_MOD_SHIFT) != 0);
    } else if (button == GLFW_MOUSE_BUTTON_LEFT || button == GLFW_MOUSE_BUTTON_MIDDLE) {
      drag->orbiting = pressed;
    } else if (button == GLFW_MOUSE_BUTTON_RIGHT) {
      drag->windowing = pressed;
    }
  };
  events.cursor = [&scene, &controller, controller_mode, drag](double x, double y) {
    const double dx = x - drag->last_x, dy = y - drag->last_y;
    drag->last_x = x, drag->last_y = y;
    if (controller_mode && controller.cursor(x, y, scene.camera_axes())) return;
    if (drag->orbiting) scene.orbit(-0.3 * dx, 0.3 * dy);
    if (drag->windowing) scene.adjust_window(2.0 * dx, std::exp(-0.005 * dy));
  };
  events.scroll = [&scene, &controller, controller_mode](double dy, int mods) {
    if (controller_mode && !(mods & GLFW_MOD_CONTROL))
      controller.scroll(-dy);  // wheel towards the user presses in
    else
      scene.zoom(std::pow(1.1, dy));
  };
  events.key = [&window, &scene, &controller, controller_mode, &requests](int key, int) {
    const CameraAxes axes = scene.camera_axes();
    if (const auto action = view_key(key)) {
      apply_view_key(*action, window, scene, controller_mode, requests);
      return;
    }
    if (!controller_mode) return;
    if (const auto input = controller_key(key)) controller.key(*input, axes);
  };
  return events;
}

}  // namespace palp::view
