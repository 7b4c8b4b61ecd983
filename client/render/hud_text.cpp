// The HUD's strings: banner_text, hud_text and force_text (pure, see hud_text.hpp).
#include "render/hud_text.hpp"

#include <cstdio>
#include <sstream>
#include <vector>

#include "base/vec.hpp"

namespace palp::view {

namespace {

std::string fixed(double value, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, value);
  return buffer;
}

}  // namespace

std::string banner_text(const LatestState& state) {
  const LinkStats& link = state.link;
  std::vector<std::string> lines;
  const std::string why = link.message.empty() ? "" : " (" + link.message + ")";
  switch (link.state) {
    case LinkState::Connecting:
      lines.push_back("CONNECTING to palpd" + why);
      break;
    case LinkState::Loading:
      lines.push_back("LOADING scene " + fixed(100.0 * link.volume_progress, 0) + "%");
      break;
    case LinkState::Stalled:
      lines.push_back("STREAM STALLED: no frame for " + fixed(link.since_last_frame_s, 1) + " s");
      break;
    case LinkState::Reconnecting:
      lines.push_back("CONNECTION LOST: reconnecting" + why);
      break;
    case LinkState::Refused:
      lines.push_back("REFUSED by palpd" + why);
      break;
    case LinkState::Live:
      break;
  }
  if (state.frame.valid) {
    const std::string dev = link.device_message.empty() ? "" : " (" + link.device_message + ")";
    if (state.frame.device_state == DeviceState::Absent) lines.push_back("DEVICE ABSENT" + dev);
    if (state.frame.device_state == DeviceState::Fault)
      lines.push_back("DEVICE FAULT " + std::to_string(state.frame.fault) + dev);
  }
  if (link.server_paused) lines.push_back("PAUSED");
  if (link.server_recording) lines.push_back("RECORDING");
  std::string out;
  for (const std::string& line : lines) out += (out.empty() ? "" : "\n") + line;
  return out;
}

std::string force_text(const LatestState& state) {
  const Vec3d& f = state.frame.force;
  std::string out = "force " + fixed(norm(f), 2) + " N  (" + fixed(f.x, 2) + ", " + fixed(f.y, 2) +
                    ", " + fixed(f.z, 2) + ")";
  if (state.scene && !state.scene->device_renders_force)
    out += "  -- force not rendered by the device";
  return out;
}

std::string task_text(const LatestState& state) {
  if (!state.task || state.task->task.empty()) return {};
  const TaskInfo& t = *state.task;
  std::string out = "task " + t.task;
  if (!t.running) out += " (stopped)";
  out += "   trial " + std::to_string(t.trial) + "   " + std::to_string(t.marks) +
         (t.marks == 1 ? " mark" : " marks");
  if (t.last_distance_mm)
    out += "   last " + fixed(*t.last_distance_mm, 1) + " mm, " + t.last_where +
           (t.last_in_target ? " (in target)" : "");
  return out;
}

std::string hud_text(const LatestState& state, const HudInputs& inputs) {
  const LinkStats& link = state.link;
  std::ostringstream out;
  out << (inputs.controller ? "controller" : "observer") << "  link " << to_string(link.state);
  if (link.connections > 1) out << " (reconnected " << link.connections - 1 << "x)";
  out << "\n";
  out << "view " << fixed(inputs.view_fps, 1) << " fps   stream " << fixed(link.frames_per_s, 0)
      << " frames/s\n";
  out << "latency "
      << (link.latency_ms >= 0 ? fixed(link.latency_ms, 1) + " ms" : std::string("n/a"))
      << "   delivered "
      << (link.delivered >= 0 ? fixed(100.0 * link.delivered, 1) + "%" : std::string("n/a"))
      << "\n";
  out << "tick rate " << fixed(link.server_tick_rate_hz, 0) << " Hz";
  if (link.server_overruns > 0) out << "   overruns " << link.server_overruns;
  out << "\n";
  if (state.scene) {
    out << "tool " << state.scene->tool << "   device " << state.scene->device << "\n";
    if (const auto& p = state.scene->placement) {
      out << "placed at " << p->home_site << "   axes " << p->axes << "   scale "
          << fixed(p->scale, 2);
      if (link.recentres > 0) out << "   re-centred " << link.recentres << "x";
      out << "\n";
    }
  }
  if (const auto& bpm = state.frame.pulse_bpm) {
    out << "pulse " << (*bpm > 0 ? fixed(*bpm, 0) + " bpm" : std::string("off"));
    // what shows at two decimals (below 0.005 N it would read 0.00)
    if (state.frame.pulse_force >= 0.005)
      out << "   felt " << fixed(state.frame.pulse_force, 2) << " N";
    if (state.frame.organ_force >= 0.005)
      out << "   organ " << fixed(state.frame.organ_force, 2) << " N";
    out << "\n";
  }
  if (const std::string task = task_text(state); !task.empty()) out << task << "\n";
  if (inputs.controller) {
    out << "keys  1/2/3 tool  space pause  O record  H re-centre  ,/. pulse -/+  B pulse on/off"
        << (state.task ? "  M mark" : "");
    if (link.last_request_id > 0)
      out << "\nlast command " << (link.last_result_ok ? "ok" : "refused")
          << (link.last_result_message.empty() ? "" : ": " + link.last_result_message);
    out << "\n";
  }
  out << "contacts " << state.frame.n_contact << "/" << state.frame.contact_points;
  out << "   deformation " << (inputs.deformation ? "on" : "off") << "\n";
  out << "preset " << to_string(inputs.preset) << "  level " << fixed(inputs.window.level, 0)
      << " width " << fixed(inputs.window.width, 0);
  if (!inputs.view.empty()) {
    out << "\ncamera " << inputs.view << " view";
    if (!inputs.orientation.empty()) out << "   CT stored " << inputs.orientation;
  }
  return out.str();
}

}  // namespace palp::view
