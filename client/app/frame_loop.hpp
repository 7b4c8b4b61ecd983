// palpview's frame loop: per frame, the window's events -> the stream's latest state ->
// the scene (state, deformation, upload, render) -> the controller's pose and requests to palpd
// -> the frame times while live -> whether to end (window closed, --duration, a screenshot
// written or not possible, refused).
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>

#include "app/pose_pump.hpp"
#include "app/view_input.hpp"
#include "app/viewer_options.hpp"
#include "app/viewer_stats.hpp"
#include "render/render_scene.hpp"
#include "scene/trajectory.hpp"
#include "stream/stream_client.hpp"
#include "window/controller_input.hpp"
#include "window/view_window.hpp"

namespace palp::view {

// What the loop drives; every reference outlives the loop.
struct FrameLoopParts {
  const Options& options;
  ViewWindow& window;
  RenderScene& scene;
  StreamClient& client;
  ControllerInput& controller;
  InputRequests& requests;
  const Trajectory& script;
  PosePump* pump;  // --controller
};

class FrameLoop {
 public:
  using Clock = std::chrono::steady_clock;

  // `start`: palpview's start (--timeout, --duration and volume_s count from it).
  FrameLoop(FrameLoopParts parts, Clock::time_point start);

  // Frames until the end; the exit code (0, or 1: refused or no screenshot in screenshot mode).
  int run();

  // The run as it ended (call after run(); live_s counts to now).
  ViewerRun result() const;

 private:
  void drive_controller();
  void send_requests();
  void note_live_frame(const DeformResult& deform, const Clock::time_point (&t)[5],
                       std::int64_t uploaded, double deform_cpu_ms);
  void count_fps();
  std::optional<int> end_code();
  double seconds_since(Clock::time_point t) const;

  FrameLoopParts p_;
  bool screenshot_;
  Clock::time_point start_;
  std::optional<Clock::time_point> live_since_;
  double volume_s_ = -1;  // seconds from start until the whole render volume was here
  PhaseTimes times_;
  int live_frames_ = 0;
  std::int64_t frames_ = 0;
  double view_fps_ = 0;
  Clock::time_point fps_window_start_;
  int fps_window_frames_ = 0;
  std::uint32_t max_contacts_ = 0;
  LatestState state_;
  bool live_ = false;
  bool refused_reported_ = false;
  bool controller_ready_ = false;
  std::uint64_t controller_connection_ = 0;
  double last_on_bpm_ = 0;  // the last heart rate above 0 (B turns the pulse back on at it)
};

}  // namespace palp::view
