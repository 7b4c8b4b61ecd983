// palpd's Commands against a loop stepped by hand: tool and parameter swaps, recording names,
// what is locked while a recording runs, and what a recording's metadata keeps.
#include "app/palpd_control.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "base/errors.hpp"
#include "loop/haptic_loop.hpp"
#include "rt/recording.hpp"
#include "scene/trajectory.hpp"
#include "support/io_test_util.hpp"
#include "support/palpd_test_util.hpp"

namespace palp::app {
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

// The newest snapshot the loop published (the ring drained).
rt::Snapshot newest(rt::HapticLoop& loop) {
  rt::Snapshot last;
  while (const rt::Snapshot* s = loop.net_ring().front()) {
    last.tick = s->tick;
    last.pulse_bpm = s->pulse_bpm;
    last.pulse_wave = s->pulse_wave;
    loop.net_ring().pop();
  }
  return last;
}

// ctl -> loop -> snapshot: SetParameter pulse_bpm goes to the loop's atomic, the next tick runs
// at it and its snapshot says so; the model is not swapped (the contacts stay), and a rate out of
// [0, 240] is refused with the range.
TEST(PalpdControl, ThePulseRateReachesTheLoopBetweenTicks) {
  SteppedLoop s;
  PalpdControl control(*s.loop, s.model->fields_ptr(), s.device, {}, "/nonexistent");
  for (int i = 0; i < 3; ++i) s.step();
  rt::Snapshot before = newest(*s.loop);
  EXPECT_EQ(before.pulse_bpm, 72.0f);  // ForceParams' default
  ASSERT_GT(before.tick.n_contact, 0);  // pressing: the pad is in contact
  EXPECT_EQ(control.set_parameter("pulse_bpm", 96.0), "");
  EXPECT_EQ(s.loop->pulse_bpm(), 96.0);
  s.step();
  const rt::Snapshot after = newest(*s.loop);
  EXPECT_EQ(after.pulse_bpm, 96.0f);
  EXPECT_EQ(after.tick.n_contact, before.tick.n_contact);  // still in contact: no restart
  EXPECT_EQ(s.loop->model(), s.model);                     // the same model, not a swapped one
  const std::string range = "pulse_bpm must be in [0, 240] beats per minute (0: no pulse)";
  EXPECT_EQ(control.set_parameter("pulse_bpm", 241.0), range);
  EXPECT_EQ(control.set_parameter("pulse_bpm", -1.0), range);
  EXPECT_EQ(control.set_parameter("pulse_bpm", std::nan("")), range);
  EXPECT_EQ(control.set_parameter("pulse_bpm", 0.0), "");  // off
  s.step();
  EXPECT_EQ(newest(*s.loop).pulse_bpm, 0.0f);
}

// The snapshots' wave follows the pulse's clock at the rate the control set: over one beat at
// 60 bpm (1000 ticks of 1 ms) it spans diastole to systole; at 0 bpm it holds.
TEST(PalpdControl, TheSnapshotsWaveBeatsAtTheRateSet) {
  SteppedLoop s;
  PalpdControl control(*s.loop, s.model->fields_ptr(), s.device, {}, "/nonexistent");
  ASSERT_EQ(control.set_parameter("pulse_bpm", 60.0), "");
  float lo = 2, hi = -1;
  for (int i = 0; i < 1000; ++i) {
    s.step();
    const float w = newest(*s.loop).pulse_wave;
    lo = std::min(lo, w), hi = std::max(hi, w);
  }
  EXPECT_GE(lo, 0.0f);
  EXPECT_LT(lo, 0.05f);  // end diastole
  EXPECT_LE(hi, 1.0f);
  EXPECT_GT(hi, 0.95f);  // the systolic peak
  ASSERT_EQ(control.set_parameter("pulse_bpm", 0.0), "");
  s.step();
  const float held = newest(*s.loop).pulse_wave;
  for (int i = 0; i < 200; ++i) {
    s.step();
    EXPECT_EQ(newest(*s.loop).pulse_wave, held);
  }
}

// The rate is fixed while recording, like the parameters, and kept in the recording's metadata
// (a replay runs at it: palpd --pulse-bpm from "pulse-bpm").
TEST(PalpdControl, ARecordingKeepsThePulseRate) {
  testing::TempDir dir("palpd-control-pulse");
  SteppedLoop s;
  PalpdControl control(*s.loop, s.model->fields_ptr(), s.device, {}, dir.path().string());
  ASSERT_EQ(control.set_parameter("pulse_bpm", 60.0), "");
  ASSERT_EQ(control.start_recording("trial-p", "controller 1"), "");
  EXPECT_EQ(control.set_parameter("pulse_bpm", 90.0), PalpdControl::kLockedWhileRecording);
  for (int i = 0; i < 5; ++i) s.step();
  EXPECT_EQ(control.stop_recording(), "");
  EXPECT_EQ(rt::read_recording(dir.file("trial-p")).metadata.at("pulse-bpm"), "60");
}

}  // namespace
}  // namespace palp::app
