// What palpview reports at exit: the frame-time split it prints, and --stats-json.
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "app/frame_times.hpp"
#include "app/viewer_options.hpp"
#include "stream/stream_client.hpp"

namespace palp::view {

// One run of the frame loop, as it ended.
struct ViewerRun {
  std::int64_t frames = 0;
  int live_frames = 0;
  double live_s = 0;     // from the first live frame to the end (0: never live)
  double volume_s = -1;  // from palpview's start until the whole volume was here (-1: never)
  std::array<int, 2> framebuffer{};
  PhaseTimes times;
  std::uint32_t max_contacts = 0;
  LatestState state;              // the last one taken
  std::optional<Pose> sent_pose;  // --controller: the controller's pose at the end
};

// The exit line, "palpview: N frames (M live), receive ... ms ...\n".
std::string frame_split_line(const ViewerRun& run);

// --stats-json's document.
nlohmann::json viewer_stats_json(const ViewerRun& run, const Options& o);

// Writes `j` (indented by 2, a newline at the end); ResourceError when it cannot.
void write_viewer_stats(const std::string& path, const nlohmann::json& j);

}  // namespace palp::view
