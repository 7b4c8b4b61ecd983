// palpview's exit report (see the header).
#include "app/viewer_stats.hpp"

#include <cstdio>
#include <fstream>
#include <vector>

#include "base/errors.hpp"

namespace palp::view {
namespace {

nlohmann::json pose_json(const Pose& p) {
  return {p.position.x,    p.position.y,    p.position.z,   p.orientation.w,
          p.orientation.x, p.orientation.y, p.orientation.z};
}

}  // namespace

std::string frame_split_line(const ViewerRun& run) {
  const PhaseTimes& times = run.times;
  const auto format = [&](char* out, std::size_t size) {
    return std::snprintf(
        out, size,
        "palpview: %lld frames (%d live), receive %.3f ms, deformation %.3f ms, upload %.3f ms "
        "(%.0f bytes), render %.3f ms per live frame (mean); render with deformation %.3f ms "
        "(%zu), without %.3f ms (%zu)\n",
        static_cast<long long>(run.frames), run.live_frames, mean_of(times.receive),
        mean_of(times.deformation), mean_of(times.upload), mean_of(times.upload_bytes),
        mean_of(times.render), mean_of(times.render_modified), times.render_modified.size(),
        mean_of(times.render_unchanged), times.render_unchanged.size());
  };
  std::vector<char> text(static_cast<std::size_t>(format(nullptr, 0)) + 1);
  format(text.data(), text.size());
  return text.data();
}

nlohmann::json viewer_stats_json(const ViewerRun& run, const Options& o) {
  const PhaseTimes& times = run.times;
  const LatestState& state = run.state;
  nlohmann::json j;
  j["frames"] = run.frames;
  j["live_frames"] = run.live_frames;
  // Rendered frames per second while live (from the first live frame to the end).
  j["frames_per_s"] = run.live_s > 0 ? run.live_frames / run.live_s : 0.0;
  j["width"] = run.framebuffer[0];
  j["height"] = run.framebuffer[1];
  j["receive_ms"] = summary(times.receive);
  j["deformation_ms"] = summary(times.deformation);
  j["volume_received_s"] = run.volume_s;  // from palpview's start: connect, handshake, chunks
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
  j["max_contacts"] = run.max_contacts;
  if (state.volume) j["volume_dims"] = state.volume->dims;
  if (state.scene) {
    j["scene_dims"] = state.scene->dims;
    j["tool"] = state.scene->tool;
  }
  j["last_frame_valid"] = state.frame.valid;
  j["last_pose"] = pose_json(state.frame.pose);
  if (o.controller && run.sent_pose) j["sent_pose"] = pose_json(*run.sent_pose);
  return j;
}

void write_viewer_stats(const std::string& path, const nlohmann::json& j) {
  std::ofstream out(path);
  out << j.dump(2) << "\n";
  if (!out) throw ResourceError("cannot write " + path);
}

}  // namespace palp::view
