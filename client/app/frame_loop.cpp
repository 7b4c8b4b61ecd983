// palpview's frame loop (see the header).
#include "app/frame_loop.hpp"

#include <algorithm>
#include <ctime>
#include <iostream>

namespace palp::view {

FrameLoop::FrameLoop(FrameLoopParts parts, Clock::time_point start)
    : p_(parts),
      screenshot_(!parts.options.screenshot.empty()),
      start_(start),
      fps_window_start_(Clock::now()) {}

double FrameLoop::seconds_since(Clock::time_point t) const {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

int FrameLoop::run() {
  while (!p_.window.should_close()) {
    p_.window.poll_events();
    Clock::time_point t[5];  // receive | deformation | upload | render
    t[0] = Clock::now();
    state_ = p_.client.latest();
    HudInputs hud;
    hud.view_fps = view_fps_;
    hud.controller = p_.options.controller;
    p_.scene.update_state(state_, hud);
    // a frame counts as live while the link is (a lost stream keeps its last frame on screen)
    live_ = state_.volume && state_.frame.valid && state_.link.state == LinkState::Live;
    if (live_ && !live_since_) live_since_ = Clock::now();
    if (state_.volume && volume_s_ < 0) volume_s_ = seconds_since(start_);  // connect -> volume
    if (p_.options.controller && state_.volume) drive_controller();
    t[1] = Clock::now();
    const double cpu1 = thread_cpu_seconds();
    const DeformResult deform = p_.scene.update_deformation();
    const double deform_cpu_ms = 1e3 * (thread_cpu_seconds() - cpu1);
    t[2] = Clock::now();
    const std::int64_t uploaded = p_.scene.upload_deformation();
    t[3] = Clock::now();
    p_.scene.render();
    t[4] = Clock::now();
    if (live_) note_live_frame(deform, t, uploaded, deform_cpu_ms);
    ++frames_;
    count_fps();
    if (const auto code = end_code()) return *code;
  }
  return 0;
}

// The controller's pose (from the input or the --script) to the pump, its requests to palpd.
void FrameLoop::drive_controller() {
  ControllerInput& controller = p_.controller;
  if (!controller_ready_ || controller_connection_ != state_.connection) {
    const RenderVolume& v = *state_.volume;
    if (!controller_ready_)
      controller.reset(initial_pose(v.dims, v.spacing, v.d_surf, 20.0, v.origin));
    controller_ready_ = true;
    controller_connection_ = state_.connection;
  }
  if (!p_.script.empty() && live_since_)
    controller.reset(script_pose(p_.script, seconds_since(*live_since_)));
  if (p_.pump) p_.pump->set(controller.pose(), live_since_);
  if (auto tool = controller.take_tool_request()) p_.client.set_tool(*tool);
  if (auto paused = controller.take_pause_request()) p_.client.set_paused(*paused);
  send_requests();
}

void FrameLoop::send_requests() {
  if (p_.requests.recentre) {
    p_.client.recentre();
    p_.requests.recentre = false;
  }
  if (p_.requests.task_mark) {
    p_.client.task_mark();
    p_.requests.task_mark = false;
  }
  if (p_.requests.record_toggle) {
    // named by the time it starts, as palp ctl does; palpd refuses a name that exists
    if (state_.link.server_recording) {
      p_.client.stop_recording();
    } else {
      const std::time_t now = std::time(nullptr);
      char name[64];
      std::strftime(name, sizeof name, "trial-%Y%m%d-%H%M%S", std::localtime(&now));
      p_.client.start_recording(name);
    }
    p_.requests.record_toggle = false;
  }
  if (p_.requests.pulse.steps != 0 || p_.requests.pulse.toggle) {
    // from the rate the frames report (an older palpd says none: SceneInfo's, else 0)
    const double now = state_.frame.pulse_bpm.value_or(state_.scene ? state_.scene->pulse_bpm : 0);
    if (const auto bpm = pulse_request(now, p_.requests.pulse, last_on_bpm_))
      p_.client.set_pulse_bpm(*bpm);
    p_.requests.pulse = {};
  }
}

void FrameLoop::note_live_frame(const DeformResult& deform, const Clock::time_point (&t)[5],
                                std::int64_t uploaded, double deform_cpu_ms) {
  const auto ms = [](Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  times_.receive.push_back(ms(t[0], t[1]));
  times_.deformation.push_back(ms(t[1], t[2]));
  times_.add_deformation(deform, deform_cpu_ms, p_.scene.deform_contacts());
  times_.upload.push_back(ms(t[2], t[3]));
  times_.upload_bytes.push_back(static_cast<double>(uploaded));
  times_.render.push_back(ms(t[3], t[4]));
  (deform.active ? times_.render_modified : times_.render_unchanged).push_back(ms(t[3], t[4]));
  if (deform.active) {
    ++times_.deform_active;
    times_.roi_voxels_sum += (deform.hi[0] - deform.lo[0]) * (deform.hi[1] - deform.lo[1]) *
                             (deform.hi[2] - deform.lo[2]);
  }
  max_contacts_ = std::max(max_contacts_, state_.frame.n_contact);
  ++live_frames_;
}

void FrameLoop::count_fps() {
  ++fps_window_frames_;
  const double fps_elapsed = seconds_since(fps_window_start_);
  if (fps_elapsed >= 0.5) {
    view_fps_ = fps_window_frames_ / fps_elapsed;
    fps_window_frames_ = 0;
    fps_window_start_ = Clock::now();
  }
}

// The exit code when this frame ends the loop.
std::optional<int> FrameLoop::end_code() {
  const Options& o = p_.options;
  const LinkStats& link = state_.link;
  const std::string why = link.message.empty() ? "" : ": " + link.message;
  if (link.state == LinkState::Refused && !refused_reported_) {
    std::cerr << "palpview: refused by " << o.host << ":" << o.port << ": " << link.message << "\n";
    refused_reported_ = true;
    if (screenshot_) return 1;
  }
  if (screenshot_) {
    // the stream went away after it had been live: no picture of a stale scene
    if (live_frames_ > 0 &&
        (link.state == LinkState::Reconnecting || link.state == LinkState::Connecting)) {
      std::cerr << "palpview: the stream from " << o.host << ":" << o.port << " was lost after "
                << live_frames_ << " of " << o.frames << " live frames"
                << (link.message.empty() ? "" : " (" + link.message + ")")
                << "; no screenshot written\n";
      return 1;
    }
    if (live_frames_ >= o.frames) {
      write_png(p_.window.render_window(), o.screenshot);
      std::cout << "palpview: wrote " << o.screenshot << " after " << live_frames_
                << " live frames\n";
      return 0;
    }
    if (seconds_since(start_) > o.timeout_s) {
      std::cerr << "palpview: no scene from " << o.host << ":" << o.port << " within "
                << o.timeout_s << " s (link " << to_string(link.state) << why << ")\n";
      return 1;
    }
  }
  if (o.duration_s > 0 && seconds_since(start_) >= o.duration_s) return 0;
  return std::nullopt;
}

ViewerRun FrameLoop::result() const {
  ViewerRun run;
  run.frames = frames_;
  run.live_frames = live_frames_;
  run.live_s = live_since_ ? seconds_since(*live_since_) : 0.0;
  run.volume_s = volume_s_;
  run.framebuffer = p_.window.framebuffer_size();
  run.times = times_;
  run.max_contacts = max_contacts_;
  run.state = state_;
  if (p_.options.controller) run.sent_pose = p_.controller.pose();
  return run;
}

}  // namespace palp::view
