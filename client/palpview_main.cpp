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
// Exit codes: 0 done, 1 failure (no display, no scene within --timeout in screenshot mode, the
// stream lost before the screenshot, refused by the server), 2 usage.
#include <GLFW/glfw3.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <functional>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "app/frame_times.hpp"
#include "app/viewer_options.hpp"
#include "base/errors.hpp"
#include "render/patient_view.hpp"
#include "render/render_scene.hpp"
#include "scene/trajectory.hpp"
#include "stream/stream_client.hpp"
#include "window/controller_input.hpp"
#include "window/view_window.hpp"

namespace palp::view {
namespace {

// The pose of a trajectory at time t (the last row with t_row <= t; the first before it).
Pose script_pose(const Trajectory& script, double t) {
  std::size_t n = 0;
  while (n + 1 < script.size() && script[n + 1].t <= t) ++n;
  return script[n].pose;
}

// Screenshot mode ends within --timeout whatever the main loop is doing. The loop checks the
// timeout after each frame and says why it ends; this is for a frame that never returns (a scene
// the checks let through that the renderer cannot draw, a driver): kDeadlineGraceS after the
// timeout it says what the link was doing and ends the process, exit code 1.
constexpr double kDeadlineGraceS = 3.0;

class Deadline {
 public:
  Deadline(double seconds, std::function<std::string()> describe) {
    thread_ = std::thread([this, seconds, describe = std::move(describe)] {
      std::unique_lock<std::mutex> lock(mutex_);
      if (done_cv_.wait_for(lock, std::chrono::duration<double>(seconds), [this] { return done_; }))
        return;
      std::fprintf(stderr, "palpview: %s\n", describe().c_str());
      std::fflush(stderr);
      std::fflush(stdout);
      std::_Exit(1);
    });
  }
  ~Deadline() {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    done_cv_.notify_all();
    thread_.join();
  }
  Deadline(const Deadline&) = delete;
  Deadline& operator=(const Deadline&) = delete;

 private:
  std::mutex mutex_;
  std::condition_variable done_cv_;
  bool done_ = false;
  std::thread thread_;
};

int run(const Options& o) {
  Trajectory script;
  if (!o.script.empty()) script = read_trajectory_csv(o.script);
  const bool screenshot = !o.screenshot.empty();

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

  // before the window: a token for another machine without TLS is never sent
  if (const std::string no = connect_refusal(stream); !no.empty()) throw UsageError(no);

  ViewWindow window(
      {o.width, o.height, !screenshot, "palpview " + o.host + ":" + std::to_string(o.port)});
  SceneSettings settings;
  settings.preset = o.preset;
  settings.deformation = o.deformation;
  settings.view = o.view;
  settings.orientation_marker = o.orientation_marker;
  settings.overlays = o.overlays;
  settings.tool_glyphs = o.tool_glyphs;
  settings.camera_azimuth_deg = o.az;
  settings.camera_elevation_deg = o.el;
  settings.camera_distance_mm = o.dist;
  settings.follow_mm = o.follow_mm;
  settings.chart_seconds = o.chart_s;
  settings.keep_outside = o.show_outside;
  RenderScene scene(window.render_window(), settings);
  ControllerInput controller;
  bool controller_ready = false;
  std::uint64_t controller_connection = 0;

  // Input mapping (see the usage text).
  bool orbiting = false, windowing = false;
  double last_x = 0, last_y = 0;
  ViewEvents events;
  events.mouse_button = [&](int button, bool pressed, double x, double y, int mods) {
    last_x = x, last_y = y;
    if (button == GLFW_MOUSE_BUTTON_LEFT && o.controller) {
      controller.button(MouseButton::Left, pressed, x, y, (mods & GLFW_MOD_SHIFT) != 0);
    } else if (button == GLFW_MOUSE_BUTTON_LEFT || button == GLFW_MOUSE_BUTTON_MIDDLE) {
      orbiting = pressed;
    } else if (button == GLFW_MOUSE_BUTTON_RIGHT) {
      windowing = pressed;
    }
  };
  events.cursor = [&](double x, double y) {
    const double dx = x - last_x, dy = y - last_y;
    last_x = x, last_y = y;
    if (o.controller && controller.cursor(x, y, scene.camera_axes())) return;
    if (orbiting) scene.orbit(-0.3 * dx, 0.3 * dy);
    if (windowing) scene.adjust_window(2.0 * dx, std::exp(-0.005 * dy));
  };
  events.scroll = [&](double dy, int mods) {
    if (o.controller && !(mods & GLFW_MOD_CONTROL))
      controller.scroll(-dy);  // wheel towards the user presses in
    else
      scene.zoom(std::pow(1.1, dy));
  };
  bool recentre_requested = false;       // H (controller): re-centre a registered device
  bool record_toggle_requested = false;  // O (controller): start or stop a recording
  events.key = [&](int key, int) {
    const CameraAxes axes = scene.camera_axes();
    switch (key) {
      case GLFW_KEY_ESCAPE:
        window.request_close();
        return;
      case GLFW_KEY_P:
        scene.set_preset(static_cast<PresetId>((static_cast<int>(scene.preset()) + 1) % 3));
        return;
      case GLFW_KEY_LEFT_BRACKET:
        scene.adjust_window(-20.0, 1.0);
        return;
      case GLFW_KEY_RIGHT_BRACKET:
        scene.adjust_window(20.0, 1.0);
        return;
      case GLFW_KEY_MINUS:
        scene.adjust_window(0.0, 1.0 / 1.2);
        return;
      case GLFW_KEY_EQUAL:
        scene.adjust_window(0.0, 1.2);
        return;
      case GLFW_KEY_HOME:
        scene.reset_camera();
        return;
      case GLFW_KEY_H:
        if (o.controller) recentre_requested = true;  // sent from the main loop below
        return;
      case GLFW_KEY_O:
        if (o.controller) record_toggle_requested = true;  // sent from the main loop below
        return;
      case GLFW_KEY_V: {
        const auto at = std::find(kViewCycle.begin(), kViewCycle.end(), scene.view());
        scene.set_view(at == kViewCycle.end() || at + 1 == kViewCycle.end() ? kViewCycle[0]
                                                                            : *(at + 1));
        return;
      }
      default:
        break;
    }
    if (!o.controller) return;
    static const std::pair<int, InputKey> kKeys[] = {
        {GLFW_KEY_LEFT, InputKey::SlideLeft},     {GLFW_KEY_RIGHT, InputKey::SlideRight},
        {GLFW_KEY_UP, InputKey::SlideUp},         {GLFW_KEY_DOWN, InputKey::SlideDown},
        {GLFW_KEY_W, InputKey::PressIn},          {GLFW_KEY_S, InputKey::PressOut},
        {GLFW_KEY_Q, InputKey::YawLeft},          {GLFW_KEY_E, InputKey::YawRight},
        {GLFW_KEY_R, InputKey::PitchUp},          {GLFW_KEY_F, InputKey::PitchDown},
        {GLFW_KEY_Z, InputKey::RollLeft},         {GLFW_KEY_C, InputKey::RollRight},
        {GLFW_KEY_1, InputKey::ToolFinger},       {GLFW_KEY_2, InputKey::ToolTwoFinger},
        {GLFW_KEY_3, InputKey::ToolProbe},        {GLFW_KEY_SPACE, InputKey::Pause},
        {GLFW_KEY_BACKSPACE, InputKey::ResetPose}};
    for (const auto& [glfw_key, input] : kKeys)
      if (glfw_key == key) controller.key(input, axes);
  };
  window.set_events(events);

  StreamClient client(stream);
  client.start();
  std::optional<Deadline> deadline;
  if (screenshot)
    deadline.emplace(o.timeout_s + kDeadlineGraceS, [&client, &o] {
      const LinkStats link = client.latest().link;
      std::ostringstream text;
      text << "no screenshot within --timeout " << o.timeout_s
           << " s: a frame did not return (link " << to_string(link.state)
           << (link.message.empty() ? "" : ": " + link.message) << "); ended";
      return text.str();
    });

  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const auto seconds_since = [](Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
  };
  std::optional<Clock::time_point> live_since;
  double volume_s = -1;  // seconds from start until the whole render volume was here

  // Controller poses leave at a steady kPosePumpHz from their own thread, whatever the render
  // rate: palpd's remote device faults after 100 ms without a pose, and a software renderer
  // (llvmpipe) draws only a few frames per second. The render thread hands over the pose the
  // input produced; a --script is sampled here, at the pump's rate, not at the frame rate.
  struct PosePump {
    std::mutex mutex;
    Pose pose{};
    bool have_pose = false;
    std::optional<Clock::time_point> live_since;
    std::atomic<bool> stop{false};
  } pump;
  constexpr double kPosePumpHz = 250.0;
  std::thread pump_thread;
  if (o.controller) {
    pump_thread = std::thread([&] {
      const auto period = std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(1.0 / kPosePumpHz));
      auto next = Clock::now();
      while (!pump.stop.load()) {
        next += period;
        std::this_thread::sleep_until(next);
        Pose pose;
        {
          const std::lock_guard<std::mutex> lock(pump.mutex);
          if (!pump.have_pose) continue;
          pose = !script.empty() && pump.live_since
                     ? script_pose(script, seconds_since(*pump.live_since))
                     : pump.pose;
        }
        client.send_pose(pose);
      }
    });
  }
  PhaseTimes times;
  int live_frames = 0;
  std::int64_t frames = 0;
  double view_fps = 0;
  auto fps_window_start = Clock::now();
  int fps_window_frames = 0;
  std::uint32_t max_contacts = 0;
  LatestState state;
  int exit_code = 0;
  bool refused_reported = false;

  while (!window.should_close()) {
    window.poll_events();
    const auto t0 = Clock::now();
    state = client.latest();
    HudInputs hud;
    hud.view_fps = view_fps;
    hud.controller = o.controller;
    scene.update_state(state, hud);
    // a frame counts as live while the link is (a lost stream keeps its last frame on screen)
    const bool live = state.volume && state.frame.valid && state.link.state == LinkState::Live;
    if (live && !live_since) live_since = Clock::now();
    if (state.volume && volume_s < 0) volume_s = seconds_since(start);  // connect -> volume

    if (o.controller && state.volume) {
      if (!controller_ready || controller_connection != state.connection) {
        const RenderVolume& v = *state.volume;
        if (!controller_ready)
          controller.reset(initial_pose(v.dims, v.spacing, v.d_surf, 20.0, v.origin));
        controller_ready = true;
        controller_connection = state.connection;
      }
      if (!script.empty() && live_since)
        controller.reset(script_pose(script, seconds_since(*live_since)));
      {
        const std::lock_guard<std::mutex> lock(pump.mutex);
        pump.pose = controller.pose();
        pump.have_pose = true;
        if (live_since) pump.live_since = live_since;
      }
      if (auto tool = controller.take_tool_request()) client.set_tool(*tool);
      if (auto paused = controller.take_pause_request()) client.set_paused(*paused);
      if (recentre_requested) {
        client.recentre();
        recentre_requested = false;
      }
      if (record_toggle_requested) {
        // named by the time it starts, as palp ctl does; palpd refuses a name that exists
        if (state.link.server_recording) {
          client.stop_recording();
        } else {
          const std::time_t now = std::time(nullptr);
          char name[64];
          std::strftime(name, sizeof name, "trial-%Y%m%d-%H%M%S", std::localtime(&now));
          client.start_recording(name);
        }
        record_toggle_requested = false;
      }
    }
    const auto t1 = Clock::now();
    const double cpu1 = thread_cpu_seconds();
    const DeformResult deform = scene.update_deformation();
    const double deform_cpu_ms = 1e3 * (thread_cpu_seconds() - cpu1);
    const auto t2 = Clock::now();
    const std::int64_t uploaded = scene.upload_deformation();
    const auto t2u = Clock::now();
    scene.render();
    const auto t3 = Clock::now();

    const auto ms = [](Clock::time_point a, Clock::time_point b) {
      return std::chrono::duration<double, std::milli>(b - a).count();
    };
    if (live) {
      times.receive.push_back(ms(t0, t1));
      times.deformation.push_back(ms(t1, t2));
      times.add_deformation(deform, deform_cpu_ms, scene.deform_contacts());
      times.upload.push_back(ms(t2, t2u));
      times.upload_bytes.push_back(static_cast<double>(uploaded));
      times.render.push_back(ms(t2u, t3));
      (deform.active ? times.render_modified : times.render_unchanged).push_back(ms(t2u, t3));
      if (deform.active) {
        ++times.deform_active;
        times.roi_voxels_sum += (deform.hi[0] - deform.lo[0]) * (deform.hi[1] - deform.lo[1]) *
                                (deform.hi[2] - deform.lo[2]);
      }
      max_contacts = std::max(max_contacts, state.frame.n_contact);
      ++live_frames;
    }
    ++frames;
    ++fps_window_frames;
    const double fps_elapsed = seconds_since(fps_window_start);
    if (fps_elapsed >= 0.5) {
      view_fps = fps_window_frames / fps_elapsed;
      fps_window_frames = 0;
      fps_window_start = Clock::now();
    }

    if (state.link.state == LinkState::Refused && !refused_reported) {
      std::cerr << "palpview: refused by " << o.host << ":" << o.port << ": " << state.link.message
                << "\n";
      refused_reported = true;
      if (screenshot) {
        exit_code = 1;
        break;
      }
    }
    if (screenshot) {
      // the stream went away after it had been live: no picture of a stale scene
      if (live_frames > 0 && (state.link.state == LinkState::Reconnecting ||
                              state.link.state == LinkState::Connecting)) {
        std::cerr << "palpview: the stream from " << o.host << ":" << o.port << " was lost after "
                  << live_frames << " of " << o.frames << " live frames"
                  << (state.link.message.empty() ? "" : " (" + state.link.message + ")")
                  << "; no screenshot written\n";
        exit_code = 1;
        break;
      }
      if (live_frames >= o.frames) {
        write_png(window.render_window(), o.screenshot);
        std::cout << "palpview: wrote " << o.screenshot << " after " << live_frames
                  << " live frames\n";
        break;
      }
      if (seconds_since(start) > o.timeout_s) {
        std::cerr << "palpview: no scene from " << o.host << ":" << o.port << " within "
                  << o.timeout_s << " s (link " << to_string(state.link.state)
                  << (state.link.message.empty() ? "" : ": " + state.link.message) << ")\n";
        exit_code = 1;
        break;
      }
    }
    if (o.duration_s > 0 && seconds_since(start) >= o.duration_s) break;
  }
  pump.stop.store(true);
  if (pump_thread.joinable()) pump_thread.join();
  client.stop();

  // The frame-time split.
  std::printf(
      "palpview: %lld frames (%d live), receive %.3f ms, deformation %.3f ms, upload %.3f ms "
      "(%.0f bytes), render %.3f ms per live frame (mean); render with deformation %.3f ms "
      "(%zu), without %.3f ms (%zu)\n",
      static_cast<long long>(frames), live_frames, mean_of(times.receive),
      mean_of(times.deformation), mean_of(times.upload), mean_of(times.upload_bytes),
      mean_of(times.render), mean_of(times.render_modified), times.render_modified.size(),
      mean_of(times.render_unchanged), times.render_unchanged.size());
  if (!o.stats_json.empty()) {
    nlohmann::json j;
    j["frames"] = frames;
    j["live_frames"] = live_frames;
    // Rendered frames per second while live (from the first live frame to the end).
    const double live_s = live_since ? seconds_since(*live_since) : 0.0;
    j["frames_per_s"] = live_s > 0 ? live_frames / live_s : 0.0;
    const auto size = window.framebuffer_size();
    j["width"] = size[0];
    j["height"] = size[1];
    j["receive_ms"] = summary(times.receive);
    j["deformation_ms"] = summary(times.deformation);
    j["volume_received_s"] = volume_s;  // from palpview's start: connect, handshake, chunks
    j["upload_ms"] = summary(times.upload);
    j["upload_bytes"] = summary(times.upload_bytes);  // the first live frame: the whole volume
    j["render_ms"] = summary(times.render);
    j["render_ms_volume_reuploaded"] = summary(times.render_modified);
    j["render_ms_volume_unchanged"] = summary(times.render_unchanged);
    j["deformation_active_frames"] = times.deform_active;
    j["roi_voxels_mean"] = times.deform_active > 0 ? static_cast<double>(times.roi_voxels_sum) /
                                                         static_cast<double>(times.deform_active)
                                                   : 0.0;
    j["deformation"] = o.deformation;
    j["deformation_split"] = deformation_split_json(times);
    j["controller"] = o.controller;
    j["link_state"] = to_string(state.link.state);
    j["stream_frames_per_s"] = state.link.frames_per_s;
    j["delivered"] = state.link.delivered;
    j["latency_ms"] = state.link.latency_ms;
    j["connections"] = state.link.connections;
    j["max_contacts"] = max_contacts;
    if (state.volume) j["volume_dims"] = state.volume->dims;
    if (state.scene) {
      j["scene_dims"] = state.scene->dims;
      j["tool"] = state.scene->tool;
    }
    const Pose& p = state.frame.pose;
    j["last_frame_valid"] = state.frame.valid;
    j["last_pose"] = {p.position.x,    p.position.y,    p.position.z,   p.orientation.w,
                      p.orientation.x, p.orientation.y, p.orientation.z};
    if (o.controller) {
      const Pose& c = controller.pose();
      j["sent_pose"] = {c.position.x,    c.position.y,    c.position.z,   c.orientation.w,
                        c.orientation.x, c.orientation.y, c.orientation.z};
    }
    std::ofstream out(o.stats_json);
    out << j.dump(2) << "\n";
    if (!out) throw ResourceError("cannot write " + o.stats_json);
  }
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
