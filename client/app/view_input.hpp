// palpview's input: the window's mouse, wheel and keys mapped to the camera, the intensity
// window, the view, and (--controller) the ControllerInput. Requests that go to palpd (re-centre,
// a recording) are left in InputRequests for the frame loop, which sends them.
#pragma once

#include "app/pulse_keys.hpp"
#include "render/render_scene.hpp"
#include "window/controller_input.hpp"
#include "window/view_window.hpp"

namespace palp::view {

// Set by the keys, taken (and cleared) by the frame loop.
struct InputRequests {
  bool recentre = false;       // H (controller): re-centre a registered device
  bool record_toggle = false;  // O (controller): start or stop a recording
  bool task_mark = false;      // M (controller): mark a training task's spot
  PulseKeys pulse;             // , . B (controller): the heart rate
};

// The callbacks for window.set_events. Every reference must outlive the window's events.
ViewEvents view_events(ViewWindow& window, RenderScene& scene, ControllerInput& controller,
                       bool controller_mode, InputRequests& requests);

}  // namespace palp::view
