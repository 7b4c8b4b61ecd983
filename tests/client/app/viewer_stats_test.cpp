// palpview's exit report without a display: the frame-time split line and --stats-json's keys
// and values for a run that never went live and one that did.
#include "app/viewer_stats.hpp"

#include <gtest/gtest.h>

#include <string>

namespace palp::view {
namespace {

TEST(ViewerStats, LineOfARunNeverLive) {
  ViewerRun run;
  run.frames = 12;
  EXPECT_EQ(frame_split_line(run),
            "palpview: 12 frames (0 live), receive 0.000 ms, deformation 0.000 ms, upload 0.000 "
            "ms (0 bytes), render 0.000 ms per live frame (mean); render with deformation 0.000 "
            "ms (0), without 0.000 ms (0)\n");
}

TEST(ViewerStats, LineMeansTheLiveFrames) {
  ViewerRun run;
  run.frames = 3;
  run.live_frames = 2;
  run.times.receive = {1.0, 2.0};
  run.times.render = {4.0, 6.0};
  run.times.render_modified = {4.0};
  run.times.render_unchanged = {6.0};
  run.times.upload_bytes = {1000, 0};
  const std::string line = frame_split_line(run);
  EXPECT_NE(line.find("3 frames (2 live), receive 1.500 ms"), std::string::npos) << line;
  EXPECT_NE(line.find("(500 bytes), render 5.000 ms"), std::string::npos) << line;
  EXPECT_NE(line.find("with deformation 4.000 ms (1), without 6.000 ms (1)"), std::string::npos)
      << line;
}

TEST(ViewerStats, JsonOfARunNeverLive) {
  ViewerRun run;
  run.frames = 5;
  run.framebuffer = {640, 480};
  Options o;
  const nlohmann::json j = viewer_stats_json(run, o);
  EXPECT_EQ(j["frames"], 5);
  EXPECT_EQ(j["live_frames"], 0);
  EXPECT_EQ(j["frames_per_s"], 0.0);
  EXPECT_EQ(j["width"], 640);
  EXPECT_EQ(j["height"], 480);
  EXPECT_EQ(j["volume_received_s"], -1.0);
  EXPECT_EQ(j["roi_voxels_mean"], 0.0);
  EXPECT_EQ(j["controller"], false);
  EXPECT_FALSE(j.contains("volume_dims"));
  EXPECT_FALSE(j.contains("scene_dims"));
  EXPECT_FALSE(j.contains("sent_pose"));
  EXPECT_EQ(j["last_pose"].size(), 7u);
  for (const char* key : {"receive_ms", "deformation_ms", "upload_ms", "upload_bytes", "render_ms",
                          "render_ms_volume_reuploaded", "render_ms_volume_unchanged",
                          "deformation_split", "link_state", "latency_ms", "max_contacts"})
    EXPECT_TRUE(j.contains(key)) << key;
}

TEST(ViewerStats, JsonOfAControllerRun) {
  ViewerRun run;
  run.live_frames = 20;
  run.live_s = 2.0;
  run.times.deform_active = 4;
  run.times.roi_voxels_sum = 100;
  run.sent_pose = Pose{};
  run.sent_pose->position = {1, 2, 3};
  Options o;
  o.controller = true;
  const nlohmann::json j = viewer_stats_json(run, o);
  EXPECT_EQ(j["frames_per_s"], 10.0);
  EXPECT_EQ(j["roi_voxels_mean"], 25.0);
  ASSERT_TRUE(j.contains("sent_pose"));
  EXPECT_EQ(j["sent_pose"][0], 1.0);
  EXPECT_EQ(j["sent_pose"][2], 3.0);
  EXPECT_EQ(j["sent_pose"][3], 1.0);  // the identity's w
}

}  // namespace
}  // namespace palp::view
