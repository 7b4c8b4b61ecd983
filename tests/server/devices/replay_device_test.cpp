// replay:FILE: poses tick by tick, recorded zero-force ticks reproduced, and a recorded session
// played back through the loop gives the recorded forces bit for bit.
#include <gtest/gtest.h>

#include <filesystem>
#include <thread>

#include "devices/device.hpp"
#include "loop/haptic_loop.hpp"
#include "rt/recording.hpp"
#include "support/palpd_test_util.hpp"

namespace palp::rt {
namespace {

TEST(ReplayDevice, PlaysRecordsInOrderThenFinishes) {
  std::vector<TickRecord> records(3);
  for (int i = 0; i < 3; ++i) records[i].pose.position = {double(i), 0, 0};
  records[1].fault = kFaultDeadline;
  ReplayDevice d(records);
  ASSERT_EQ(d.configure({}), DeviceStatus::Ok);
  ASSERT_EQ(d.activate(), DeviceStatus::Ok);
  DeviceSample s;
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(d.read(999, s), DeviceStatus::Ok);  // time does not matter
    EXPECT_EQ(s.pose.position.x, double(i));
    EXPECT_EQ(s.forced_fault, i == 1 ? kFaultDeadline : 0u);
  }
  EXPECT_EQ(d.read(0, s), DeviceStatus::Finished);
  EXPECT_EQ(ReplayDevice({}).configure({}), DeviceStatus::Error);
}

// Records a session of the loop on its thread (sim device, falcon limits, a pause in the middle),
// then replays the file through a fresh loop with step(): every force, torque, displacement,
// contact count and status bit matches.
TEST(ReplayDevice, ReproducesARecordedSessionBitForBit) {
  const auto model = testing::ball_model("finger:19");
  Trajectory path;
  for (int i = 0; i < 400; ++i) {
    TrajectorySample s;
    s.t = i * 0.0005;
    const double depth = -1.0 + 6.0 * std::sin(3.14159 * i / 400.0);
    s.pose = testing::press_pose(depth, 0.02 * i);
    path.push_back(s);
  }
  SimDevice sim(path);
  DeviceConfig dc;
  dc.rate_hz = 2000;
  ASSERT_EQ(sim.configure(dc), DeviceStatus::Ok);
  ASSERT_EQ(sim.activate(), DeviceStatus::Ok);
  LoopConfig lc;
  lc.rate_hz = 2000;
  lc.realtime = false;
  lc.watchdog_late_s = 0.002;  // faults may happen on a busy machine: they are replayed too
  lc.profile = &device_profile("falcon");
  const std::string path_out = (std::filesystem::temp_directory_path() /
                                ("palp-replay-" + std::to_string(::getpid()) + ".palprec"))
                                   .string();
  std::uint64_t recorded = 0;
  {
    HapticLoop loop(model, sim, lc);
    const std::uint64_t first = loop.set_recording(true);
    Recorder recorder(loop.record_ring(), path_out, {{"tool", "finger:19"}}, first);
    loop.start();
    while (loop.stats().ticks < 150) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    loop.set_paused(true);
    const std::uint64_t paused_at = loop.stats().ticks;
    while (loop.stats().ticks < paused_at + 20)
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    loop.set_paused(false);
    while (loop.stats().ticks < paused_at + 250)
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    loop.set_recording(false);
    loop.stop();
    recorder.stop();
    recorded = recorder.count();
    EXPECT_EQ(loop.stats().record_dropped, 0u);
  }
  const Recording rec = read_recording(path_out);
  ASSERT_EQ(rec.records.size(), recorded);
  ASSERT_GT(rec.records.size(), 300u);
  int paused = 0, touching = 0;
  for (const TickRecord& r : rec.records) {
    paused += (r.fault & kZeroPaused) != 0;
    touching += r.n_contact > 0;
  }
  EXPECT_GT(paused, 0);
  EXPECT_GT(touching, 50);

  ReplayDevice replay(rec.records);
  ASSERT_EQ(replay.configure({}), DeviceStatus::Ok);
  ASSERT_EQ(replay.activate(), DeviceStatus::Ok);
  LoopConfig rc = lc;
  rc.record_slots = 4096;
  rc.net_slots = 8;
  HapticLoop again(model, replay, rc);
  again.set_recording(true);
  std::vector<TickRecord> replayed;
  for (std::int64_t n = 0; !again.finished(); ++n) {
    again.step(n * 500'000, n * 500'000);  // on time: no new faults
    while (const Snapshot* s = again.record_ring().front()) {
      replayed.push_back(s->tick);
      again.record_ring().pop();
    }
  }
  ASSERT_EQ(replayed.size(), rec.records.size());
  std::size_t mismatches = 0;
  for (std::size_t i = 0; i < replayed.size(); ++i) {
    const TickRecord& a = rec.records[i];
    const TickRecord& b = replayed[i];
    const bool same = a.pose.position == b.pose.position && a.force == b.force &&
                      a.torque == b.torque && a.u == b.u && a.n_contact == b.n_contact &&
                      a.tick_status == b.tick_status && a.safety_status == b.safety_status &&
                      a.fault == b.fault;
    if (!same && mismatches++ < 3) ADD_FAILURE() << "tick " << i << " differs";
  }
  EXPECT_EQ(mismatches, 0u);
  std::filesystem::remove(path_out);
  std::filesystem::remove(csv_path_for(path_out));
}

}  // namespace
}  // namespace palp::rt
