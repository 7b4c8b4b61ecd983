// palpview's key bindings (see the usage text): which GLFW key does what, as a table with no
// window behind it. The view's keys act in every palpview; the controller's only with
// --controller (ControllerInput maps them to poses and commands).
#pragma once

#include <optional>

#include "window/controller_input.hpp"

namespace palp::view {

enum class ViewKey {
  Close,            // Escape
  NextPreset,       // P
  LevelDown,        // [  the intensity window's centre
  LevelUp,          // ]
  Narrower,         // -  the intensity window's width
  Wider,            // =
  ResetCamera,      // Home
  Recentre,         // H  (controller) re-centre a registered device
  ToggleRecording,  // O  (controller) start or stop a recording
  NextView,         // V  the next of kViewCycle
  PulseSlower,      // ,  (controller) the arteries' heart rate down (pulse_keys.hpp)
  PulseFaster,      // .  (controller) and up
  PulseToggle,      // B  (controller) the pulse off, and back on
  TaskMark,         // M  (controller) mark the spot of a training task (palpd scores it)
  ToggleLandmarks,  // L  show the landmarks (never to the trainee while a task runs)
};

// The view's action for a GLFW key (GLFW_KEY_*), if it has one.
std::optional<ViewKey> view_key(int glfw_key);

// The controller's input for a GLFW key, if it has one.
std::optional<InputKey> controller_key(int glfw_key);

}  // namespace palp::view
