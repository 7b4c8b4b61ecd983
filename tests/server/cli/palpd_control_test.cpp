// palpd's Commands against a loop stepped by hand: tool and parameter swaps, recording names,
// what is locked while a recording runs, and what a recording's metadata keeps.
#include "cli/palpd_control.hpp"

#include <gtest/gtest.h>

#include <optional>

#include "base/errors.hpp"
#include "loop/haptic_loop.hpp"
#include "rt/recording.hpp"
#include "scene/trajectory.hpp"
#include "support/io_test_util.hpp"
#include "support/palpd_test_util.hpp"

namespace palp::cli {
namespace {

struct SteppedLoop {
  SteppedLoop() : model(testing::ball_model("finger:7")) {
    device.script.push_back({rt::DeviceStatus::Ok, testing::press_pose(1.0)});
    device.writes.reserve(64);
    device.write_after_read.reserve(64);
    rt::LoopConfig c;
    c.realtime = false;
    loop.emplace(model, device, c);
  }
  void step() {
    loop->step(t, t);
    t += 1'000'000;
  }
  std::shared_ptr<const Model> model;
  testing::ScriptedDevice device;
  std::optional<rt::HapticLoop> loop;
  std::int64_t t = 0;
};

TEST(PalpdControl, ToolAndParameterChangesReachTheLoop) {
  SteppedLoop s;
  PalpdControl control(*s.loop, s.model->fields_ptr(), s.device, {}, "/nonexistent");
  EXPECT_EQ(control.set_tool("finger:1"), "");
  s.step();
  EXPECT_EQ(s.loop->model()->tool().points.size(), 1u);
  EXPECT_EQ(control.set_parameter("k", 0.25), "");
  s.step();
  EXPECT_EQ(s.loop->model()->params().k, 0.25);
  EXPECT_EQ(s.loop->model()->tool().points.size(), 1u);  // the tool stays
  EXPECT_THROW(control.set_parameter("no_such_parameter", 1.0), Error);
  EXPECT_FALSE(control.set_device_pose(Pose{}, 0));  // not a remote device
  EXPECT_EQ(control.recentre(),
            "this device moves in the scene frame (no registration): nothing to re-centre");
}

TEST(PalpdControl, RecordingNamesArePlainFileNames) {
  SteppedLoop s;
  PalpdControl control(*s.loop, s.model->fields_ptr(), s.device, {}, "/nonexistent");
  const std::string plain =
      "recording name must be a plain file name (no '/', not starting with '.')";
  EXPECT_EQ(control.start_recording("", "test"), plain);
  EXPECT_EQ(control.start_recording("../escape", "test"), plain);
  EXPECT_EQ(control.start_recording(".hidden", "test"), plain);
  EXPECT_EQ(control.start_recording(std::string(129, 'a'), "test"), plain);
  EXPECT_EQ(control.start_recording(std::string("bell\x07"), "test"),
            "recording name must not hold control characters");
  EXPECT_FALSE(control.recording());
}

TEST(PalpdControl, ARecordingLocksToolAndParametersAndKeepsThemInItsMetadata) {
  testing::TempDir dir("palpd-control");
  SteppedLoop s;
  PalpdControl control(*s.loop, s.model->fields_ptr(), s.device, {{"scene", "ball"}},
                       dir.path().string());
  ASSERT_EQ(control.start_recording("trial-1", "controller 1"), "");
  EXPECT_TRUE(control.recording());
  EXPECT_EQ(control.start_recording("trial-2", "controller 1"),
            "already recording to " + dir.file("trial-1"));
  EXPECT_EQ(control.set_tool("finger:1"), PalpdControl::kLockedWhileRecording);
  EXPECT_EQ(control.set_parameter("k", 0.25), PalpdControl::kLockedWhileRecording);
  for (int i = 0; i < 20; ++i) s.step();
  EXPECT_EQ(control.stop_recording(), "");
  EXPECT_EQ(control.stop_recording(), "not recording");
  const rt::Recording r = rt::read_recording(dir.file("trial-1"));
  EXPECT_EQ(r.records.size(), 20u);
  EXPECT_EQ(r.metadata.at("scene"), "ball");
  EXPECT_EQ(r.metadata.at("tool"), "finger:7");
  EXPECT_EQ(r.metadata.at("started-by"), "controller 1");
  EXPECT_EQ(r.metadata.at("param.k"), number_text(s.model->params().k));
  EXPECT_EQ(control.set_tool("finger:1"), "");  // unlocked again
}

}  // namespace
}  // namespace palp::cli
