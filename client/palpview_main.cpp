// palpview: the render client. Connects to palpd, shows the volume, the tool, its contacts and
// proxies, the force, and the skin deformation; observes, or (--controller) drives palpd's
// `remote` device with mouse and keyboard (or a scripted trajectory, --script).
//
// Data flow per frame:
//   GLFW events -> camera / windowing / ControllerInput
//   StreamClient::latest() -> RenderScene::update_state          (receive)
//   RenderScene::update_deformation (SkinDeformer, in place)       (deformation)
//   RenderScene::render (VTK ray casting + geometry + HUD)         (render)
//   controller: pose -> pose pump thread (250 Hz) -> StreamClient::send_pose;
//               tool / pause requests -> commands
// At exit the frame-time split is printed and (--stats-json) written as JSON.
// parse (app/viewer_options) -> build (stream options, window, scene, input: app/view_input)
// -> run (app/frame_loop, app/pose_pump, app/deadline) -> report (app/viewer_stats).
// Exit codes: 0 done, 1 failure (no display, no scene within --timeout in screenshot mode, the
// stream lost before the screenshot, refused by the server), 2 usage.
#include <chrono>
#include <cstdio>
#include <exception>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>

#include "app/deadline.hpp"
#include "app/frame_loop.hpp"
#include "app/pose_pump.hpp"
#include "app/view_input.hpp"
#include "app/viewer_options.hpp"
#include "app/viewer_stats.hpp"
#include "base/errors.hpp"
#include "render/render_scene.hpp"
#include "scene/trajectory.hpp"
#include "stream/stream_client.hpp"
#include "window/controller_input.hpp"
#include "window/view_window.hpp"

namespace palp::view {
namespace {

StreamOptions stream_options(const Options& o) {
  StreamOptions stream;
  stream.host = o.host;
  stream.port = o.port;
  stream.dds = o.dds, stream.dds_domain = o.dds_domain, stream.dds_rig = o.dds_rig;
  stream.controller = o.controller;
  stream.token = o.token;
  stream.tls_ca = o.tls_ca;
  stream.tls_pin = o.tls_pin;
  stream.tls_cert = o.tls_cert;
  stream.tls_key = o.tls_key;
  stream.client_name = o.name;
  stream.frame_rate_hz = o.rate_hz;
  stream.volume_max_dim = o.volume_max_dim;
  stream.volume_hu = o.ct;
  stream.volume_bone = !o.ct;            // the CT's presets never read d_bone
  stream.volume_crop = !o.show_outside;  // the body's box, unless the outside is wanted
  stream.force_history_s = o.chart_s;
  return stream;
}

SceneSettings scene_settings(const Options& o) {
  SceneSettings settings;
  settings.preset = o.preset;
  settings.deformation = o.deformation;
  settings.view = o.view;
  settings.orientation_marker = o.orientation_marker;
  settings.overlays = o.overlays;
  settings.tool_glyphs = o.tool_glyphs;
  settings.show_landmarks = o.show_landmarks;
  settings.camera_azimuth_deg = o.az;
  settings.camera_elevation_deg = o.el;
  settings.camera_distance_mm = o.dist;
  settings.follow_mm = o.follow_mm;
  settings.chart_seconds = o.chart_s;
  settings.keep_outside = o.show_outside;
  settings.skin_from_volume = o.skin_hu;
  return settings;
}

// What the screenshot deadline says when a frame did not return.
std::string deadline_text(const StreamClient& client, const Options& o) {
  const LinkStats link = client.latest().link;
  std::ostringstream text;
  text << "no screenshot within --timeout " << o.timeout_s << " s: a frame did not return (link "
       << to_string(link.state) << (link.message.empty() ? "" : ": " + link.message) << "); ended";
  return text.str();
}

int run(const Options& o) {
  Trajectory script;
  if (!o.script.empty()) script = read_trajectory_csv(o.script);
  const bool screenshot = !o.screenshot.empty();
  const StreamOptions stream = stream_options(o);
  // before the window: a token for another machine without TLS is never sent
  if (const std::string no = connect_refusal(stream); !no.empty()) throw UsageError(no);

  ViewWindow window(
      {o.width, o.height, !screenshot, "palpview " + o.host + ":" + std::to_string(o.port)});
  RenderScene scene(window.render_window(), scene_settings(o));
  ControllerInput controller;
  InputRequests requests;
  window.set_events(view_events(window, scene, controller, o.controller, requests));

  StreamClient client(stream);
  client.start();
  std::optional<Deadline> deadline;
  if (screenshot)
    deadline.emplace(o.timeout_s + kDeadlineGraceS,
                     [&client, &o] { return deadline_text(client, o); });
  const auto start = std::chrono::steady_clock::now();
  std::optional<PosePump> pump;
  if (o.controller) pump.emplace(client, script);
  FrameLoop frames(
      {o, window, scene, client, controller, requests, script, pump ? &*pump : nullptr}, start);
  const int exit_code = frames.run();
  pump.reset();
  client.stop();

  const ViewerRun result = frames.result();
  std::fputs(frame_split_line(result).c_str(), stdout);
  if (!o.stats_json.empty()) write_viewer_stats(o.stats_json, viewer_stats_json(result, o));
  return exit_code;
}

}  // namespace
}  // namespace palp::view

int main(int argc, char** argv) {
  using namespace palp;
  std::optional<view::Options> options;
  try {
    options = view::parse_options(argc, argv);
  } catch (const UsageError& e) {
    std::cerr << "palpview: " << e.what() << "\n(palpview --help for the options)\n";
    return 2;
  }
  if (!options) {
    std::cout << view::kUsage;
    return 0;
  }
  try {
    return view::run(*options);
  } catch (const UsageError& e) {
    std::cerr << "palpview: " << e.what() << "\n";
    return 2;
  } catch (const Error& e) {
    std::cerr << "palpview: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "palpview: " << e.what() << "\n";
    return 1;
  }
}
