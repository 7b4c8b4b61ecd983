// The HUD's strings (text block, banner, force line) as pure functions of the stream state.
//
// render_scene.hpp includes this header; the strings are testable without a display. The text
// actors that show them are in hud_layer.hpp.
#pragma once

#include <string>

#include "render/transfer_presets.hpp"
#include "stream/stream_client.hpp"

namespace palp::view {

// What the HUD shows besides the stream's own state.
struct HudInputs {
  double view_fps = 0;  // frames/s rendered by palpview
  PresetId preset = PresetId::Skin;
  Window window;
  bool controller = false;
  bool deformation = true;
  std::string view;         // the camera's view in patient terms ("anterior"); empty: not shown
  std::string orientation;  // the CT's stored orientation code ("LPS", "RAS")
};

// The banner (empty when all is well): connection problems, a stalled stream, an absent or
// faulty device, a paused loop. One line per problem.
std::string banner_text(const LatestState& state);
// The HUD's text block: link, rates, latency, delivered fraction, tick rate, tool, contacts.
std::string hud_text(const LatestState& state, const HudInputs& inputs);
// The training task's line ("" without a task): the task, the trial, the marks and, for
// observers, the last mark's score.
std::string task_text(const LatestState& state);
// The force line next to the chart, with "force not rendered by the device" when the device does
// not render force (SceneDescription::device_renders_force false).
std::string force_text(const LatestState& state);

}  // namespace palp::view
