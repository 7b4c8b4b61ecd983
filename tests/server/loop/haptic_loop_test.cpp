// The haptic loop, stepped deterministically (step()) with scripted devices, and once on its
// thread. No assertion depends on timing.
#include "loop/haptic_loop.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "support/heap_allocation_counter.hpp"

#include <atomic>
#include <cstdlib>
#include <new>
#include <thread>

#include "base/errors.hpp"
#include "support/palpd_test_util.hpp"

namespace palp::rt {
namespace {

using testing::ScriptedDevice;

constexpr std::int64_t kPeriod = 1'000'000;  // 1 kHz

LoopConfig quiet_config() {
  LoopConfig c;
  c.realtime = false;
  c.watchdog_late_s = 0.005;
  c.device_timeout_s = 0.010;
  return c;
}

ScriptedDevice pressing_device(std::size_t ticks) {
  ScriptedDevice d;
  for (std::size_t i = 0; i < ticks; ++i)
    d.script.push_back(
        {DeviceStatus::Ok, testing::press_pose(0.5 + 0.01 * double(i), 0.02 * double(i))});
  d.writes.reserve(4 * ticks + 16);
  d.write_after_read.reserve(4 * ticks + 16);
  return d;
}

// Drains the loop's network ring into a vector of tick records.
std::vector<TickRecord> drain(HapticLoop& loop) {
  std::vector<TickRecord> out;
  while (const Snapshot* s = loop.net_ring().front()) {
    out.push_back(s->tick);
    loop.net_ring().pop();
  }
  return out;
}

TEST(JitterBucket, Bounds) {
  EXPECT_EQ(jitter_bucket(-5), 0u);
  EXPECT_EQ(jitter_bucket(0), 0u);
  EXPECT_EQ(jitter_bucket(999), 0u);   // < 1 us
  EXPECT_EQ(jitter_bucket(1000), 1u);  // [1, 2) us
  EXPECT_EQ(jitter_bucket(4999), 2u);  // [2, 5) us
  EXPECT_EQ(jitter_bucket(4'999'999), 11u);
  EXPECT_EQ(jitter_bucket(5'000'000), 12u);  // beyond the last bound
}

TEST(HapticLoop, RefusesBadRates) {
  auto model = testing::ball_model();
  ScriptedDevice d = pressing_device(1);
  LoopConfig c = quiet_config();
  c.rate_hz = 0.5;
  EXPECT_THROW((HapticLoop{model, d, c}), UsageError);
  c.rate_hz = 2e5;
  EXPECT_THROW((HapticLoop{model, d, c}), UsageError);
}

TEST(HapticLoop, ForcesAreTheModelsExactly) {
  auto model = testing::ball_model();
  ScriptedDevice d = pressing_device(50);
  HapticLoop loop(model, d, quiet_config());
  State reference = make_state(*model);
  for (std::int64_t n = 0; n < 50; ++n) loop.step(n * kPeriod, n * kPeriod + 20'000);
  const std::vector<TickRecord> records = drain(loop);
  ASSERT_EQ(records.size(), 50u);
  int touching = 0;
  for (std::size_t n = 0; n < 50; ++n) {
    tick(*model, reference, d.script[n].pose);
    EXPECT_EQ(records[n].seq, n);
    EXPECT_EQ(records[n].t_ns, std::int64_t(n) * kPeriod);
    EXPECT_EQ(records[n].late_ns, 20'000);
    EXPECT_EQ(records[n].fault, 0u);
    EXPECT_EQ(records[n].force, reference.f_device);
    EXPECT_EQ(records[n].torque, reference.tau_device);
    EXPECT_EQ(records[n].u, reference.u);
    EXPECT_EQ(records[n].n_contact, reference.n_contact);
    EXPECT_EQ(d.writes[n].force, reference.f_device);
    touching += reference.n_contact > 0;
  }
  EXPECT_EQ(touching, 50);
  const LoopStats s = loop.stats();
  EXPECT_EQ(s.ticks, 50u);
  EXPECT_EQ(s.faults, 0u);
  EXPECT_EQ(s.jitter[jitter_bucket(20'000)], 50u);
  EXPECT_EQ(s.max_late_ns, 20'000);
  EXPECT_EQ(s.net_published, 50u);
}

// A registered device: poses are moved into the scene, forces sent back in the device frame, and
// both are the model's exactly (the registration of scale 1 and an axis permutation is exact).
TEST(HapticLoop, RegisteredDeviceFeelsTheSceneForceInItsFrame) {
  auto model = testing::ball_model();
  Registration reg;
  reg.rotation = rotation_from_axes(PatientFrame{}, "IAR");
  reg.home = {40, 10, 60};
  ScriptedDevice d;
  std::vector<Pose> scene_poses;
  for (int i = 0; i < 20; ++i) {
    const Pose scene = testing::press_pose(0.5 + 0.1 * i);
    scene_poses.push_back(scene);
    Pose device;
    device.position = scene_point_to_device(reg, scene.position);
    // The tool's orientation in the scene stays the identity: device turn = R⁻¹.
    device.orientation = Quat{0, std::sqrt(0.5), 0, -std::sqrt(0.5)};  // R = IAR's rotation
    d.script.push_back({DeviceStatus::Ok, device});
  }
  d.writes.reserve(64);
  d.write_after_read.reserve(64);
  LoopConfig c = quiet_config();
  c.registration = reg;
  HapticLoop loop(model, d, c);
  State reference = make_state(*model);
  for (std::int64_t n = 0; n < 20; ++n) loop.step(n * kPeriod, n * kPeriod + 20'000);
  const std::vector<TickRecord> records = drain(loop);
  ASSERT_EQ(records.size(), 20u);
  for (std::size_t n = 0; n < 20; ++n) {
    Pose scene = to_scene(reg, d.script[n].pose);
    EXPECT_NEAR(norm(scene.position - scene_poses[n].position), 0.0, 1e-12);
    tick(*model, reference, scene);
    EXPECT_EQ(records[n].pose.position, scene.position);
    EXPECT_EQ(records[n].force, force_to_scene(reg, force_to_device(reg, reference.f_device)));
    EXPECT_EQ(d.writes[n].force, force_to_device(reg, reference.f_device));
    EXPECT_GT(reference.n_contact, 0);
  }
}

// A re-centre waits while the finger is in contact; once lifted, home moves so that where the
// device is now maps to the configured home point.
TEST(HapticLoop, RecentreWaitsForLiftOffThenMovesHome) {
  auto model = testing::ball_model();
  Registration reg;
  reg.rotation = rotation_from_axes(PatientFrame{}, "IAR");
  reg.home = {31, 31, 90};  // 20 mm above the top of the ball... and 8 more for the pad
  ScriptedDevice d;
  Pose pressing;
  pressing.position = scene_point_to_device(reg, testing::press_pose(1.0).position);
  pressing.orientation = Quat{0, std::sqrt(0.5), 0, -std::sqrt(0.5)};  // tool upright in the scene
  Pose lifted;
  lifted.position = {5, 7, -3};  // away from the ball: no contact
  d.script = {{DeviceStatus::Ok, pressing},
              {DeviceStatus::Ok, pressing},
              {DeviceStatus::Ok, lifted},
              {DeviceStatus::Ok, lifted},
              {DeviceStatus::Ok, lifted}};
  d.writes.reserve(64);
  d.write_after_read.reserve(64);
  LoopConfig c = quiet_config();
  c.registration = reg;
  HapticLoop loop(model, d, c);
  loop.step(0, 20'000);
  loop.request_recentre();
  loop.step(kPeriod, kPeriod + 20'000);  // in contact: waits
  EXPECT_EQ(loop.stats().recentres, 0u);
  loop.step(2 * kPeriod, 2 * kPeriod + 20'000);  // lifted this tick; the last tick touched
  EXPECT_EQ(loop.stats().recentres, 0u);
  loop.step(3 * kPeriod, 3 * kPeriod + 20'000);  // out of contact: re-centred
  EXPECT_EQ(loop.stats().recentres, 1u);
  const Vec3d moved = to_scene(Registration{reg.rotation, 1.0, {}}, lifted).position;
  EXPECT_EQ(loop.registration_home(), reg.home - moved);
  const std::vector<TickRecord> records = drain(loop);
  ASSERT_EQ(records.size(), 4u);
  EXPECT_GT(records[1].n_contact, 0);
  EXPECT_EQ(records[3].pose.position, reg.home);  // the device now sits at the home point
}

// With engagement: no force until the finger is out of contact, then a ramp; a device fault
// mid-press zeroes the force and it comes back as a ramp after lift-off, never as a step.
TEST(HapticLoop, FaultAndRecoveryRampTheForceBackIn) {
  auto model = testing::ball_model();
  ScriptedDevice d;
  Pose lifted;
  lifted.position = {31, 31, 90};
  const Pose pressing = testing::press_pose(3.0);
  auto add = [&](DeviceStatus status, const Pose& pose, int n) {
    for (int i = 0; i < n; ++i) d.script.push_back({status, pose});
  };
  add(DeviceStatus::Ok, pressing, 3);  // start pressing: held off
  add(DeviceStatus::Ok, lifted, 2);    // lift: engages
  add(DeviceStatus::Ok, pressing, 8);  // press during and after the 5-tick ramp
  add(DeviceStatus::Error, pressing, 1);
  add(DeviceStatus::Ok, pressing, 3);  // still pressing after the fault: held off
  add(DeviceStatus::Ok, lifted, 1);
  add(DeviceStatus::Ok, pressing, 6);
  d.writes.reserve(256);
  d.write_after_read.reserve(256);
  LoopConfig c = quiet_config();
  c.profile = &device_profile("falcon");
  c.engage = EngageParams{0.2, 0.005};  // 5 ticks at 1 kHz
  HapticLoop loop(model, d, c);
  const int ticks = static_cast<int>(d.script.size());
  for (int n = 0; n < ticks; ++n) loop.step(n * kPeriod, n * kPeriod + 20'000);
  const std::vector<TickRecord> r = drain(loop);
  ASSERT_EQ(r.size(), static_cast<std::size_t>(ticks));
  for (int n = 0; n < 3; ++n) {
    EXPECT_EQ(norm(r[n].force), 0.0) << n;  // in contact before engagement: nothing
    EXPECT_NE(r[n].safety_status & kSafetyEngaging, 0u);
  }
  // Pressing after engagement: the force grows by at most the ramp's share each tick.
  double previous = 0.0;
  for (int n = 5; n < 13; ++n) {
    const double f = norm(r[n].force);
    EXPECT_LE(f - previous, 8.0 / 5.0 + 1e-9) << n;  // falcon's 8 N over the 5-tick ramp
    previous = f;
  }
  EXPECT_GT(norm(r[12].force), 0.1);  // pushing back (the falcon profile lets it settle slowly)
  EXPECT_EQ(r[12].safety_status & kSafetyEngaging, 0u);
  EXPECT_NE(r[13].fault, 0u);
  for (int n = 14; n < 17; ++n) EXPECT_EQ(norm(r[n].force), 0.0) << n;  // held off again
  previous = 0.0;
  for (int n = 18; n < ticks; ++n) {
    const double f = norm(r[n].force);
    EXPECT_LE(f - previous, 8.0 / 5.0 + 1e-9) << n;
    previous = f;
  }
}

TEST(HapticLoop, DeviceProfileLimitsTheForce) {
  auto model = testing::ball_model();
  ScriptedDevice d;
  d.script = {{DeviceStatus::Ok, testing::press_pose(6.0)}};  // deep: about 5 N a point
  LoopConfig c = quiet_config();
  c.profile = &device_profile("falcon");
  HapticLoop loop(model, d, c);
  loop.step(0, 0);
  const TickRecord r = drain(loop).at(0);
  // The loop runs the force chain (coupling on, no engagement or passivity configured) on the
  // model's force at the coupling's tool, which starts at the device.
  State state = make_state(*model);
  tick(*model, state, d.script[0].pose);
  ForceChainState chain;
  ForceChainConfig chain_config;
  EXPECT_EQ(force_chain_tool(chain, chain_config, d.script[0].pose.position),
            d.script[0].pose.position);
  const ForceChainOutput expected =
      run_force_chain(chain, chain_config, device_profile("falcon"), state.f_device,
                      state.tau_device, state.stiffness, d.script[0].pose.position,
                      0.001);  // the nominal period, never the measured one
  EXPECT_GT(norm(state.f_device), 1.0);
  EXPECT_EQ(r.force, expected.force);
  EXPECT_EQ(r.safety_status, expected.status);
  EXPECT_NE(r.safety_status, 0u);
  EXPECT_LT(norm(r.force), 1.6 + 1e-9);  // at most 1600 N/s for 1 ms from zero
}

TEST(HapticLoop, LateTickZeroesForceBeforeReadingTheDevice) {
  auto model = testing::ball_model();
  ScriptedDevice d = pressing_device(3);
  HapticLoop loop(model, d, quiet_config());
  loop.step(0, 0);
  loop.step(kPeriod, kPeriod + 6'000'000);  // 6 ms late > 5 ms watchdog
  loop.step(2 * kPeriod, 2 * kPeriod);
  const std::vector<TickRecord> r = drain(loop);
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r[1].fault, kFaultDeadline);
  EXPECT_EQ(r[1].force, Vec3d{});
  EXPECT_EQ(r[1].n_contact, 0);
  // The write of zero came before the second read.
  ASSERT_GE(d.writes.size(), 2u);
  EXPECT_EQ(d.writes[1].force, Vec3d{});
  EXPECT_EQ(d.write_after_read[1], 1);
  EXPECT_EQ(r[2].fault, 0u);
  EXPECT_GT(r[2].n_contact, 0);
  const LoopStats s = loop.stats();
  EXPECT_EQ(s.faults, 1u);
  EXPECT_EQ(s.last_fault, kFaultDeadline);
}

TEST(HapticLoop, DeviceFaultsZeroTheForce) {
  auto model = testing::ball_model();
  ScriptedDevice d;
  const Pose p = testing::press_pose(2.0);
  d.script = {{DeviceStatus::Ok, p},           {DeviceStatus::Timeout, p}, {DeviceStatus::Ok, p},
              {DeviceStatus::Disconnected, p}, {DeviceStatus::Error, p},   {DeviceStatus::Ok, p}};
  d.writes.reserve(64);
  d.write_after_read.reserve(64);
  HapticLoop loop(model, d, quiet_config());
  for (int n = 0; n < 6; ++n) loop.step(n * kPeriod, n * kPeriod);
  const std::vector<TickRecord> r = drain(loop);
  ASSERT_EQ(r.size(), 6u);
  const std::uint32_t expected[] = {0, kFaultDeviceTimeout, 0, kFaultDeviceLost, kFaultDeviceLost,
                                    0};
  for (int n = 0; n < 6; ++n) {
    EXPECT_EQ(r[n].fault, expected[n]) << n;
    if (expected[n]) {
      EXPECT_EQ(r[n].force, Vec3d{}) << n;
    } else {
      EXPECT_GT(norm(r[n].force), 0.0) << n;
    }
  }
  EXPECT_EQ(loop.stats().faults, 3u);
}

// Hot-plug: Absent zeroes the force from that tick on without a fault, counts one event per
// unplug, puts the state into each snapshot, and after the replug waits for a fresh pose.
// The remote device whose controller leaves: one absent period, no fault per tick (a lab's idle
// rig shows 0 faults, as operations.md says), and contact resumes when poses come again.
TEST(HapticLoop, ARemoteControllerLeavingIsOneAbsentEventNotFaults) {
  auto model = testing::ball_model();
  RemoteDevice d;
  DeviceConfig dc;
  dc.timeout_s = 0.005;  // 5 ticks
  ASSERT_EQ(d.configure(dc), DeviceStatus::Ok);
  ASSERT_EQ(d.activate(), DeviceStatus::Ok);
  HapticLoop loop(model, d, quiet_config());
  d.submit(testing::press_pose(2.0), 0);
  for (int n = 0; n < 100; ++n) loop.step(n * kPeriod, n * kPeriod);  // 95 ticks with no pose
  LoopStats s = loop.stats();
  EXPECT_EQ(s.faults, 0u);
  EXPECT_EQ(s.absent_events, 1u);
  EXPECT_EQ(s.device_state, DeviceState::Absent);
  d.submit(testing::press_pose(2.0), 100 * kPeriod);
  loop.step(100 * kPeriod, 100 * kPeriod);
  s = loop.stats();
  EXPECT_EQ(s.device_state, DeviceState::Present);
  EXPECT_EQ(s.faults, 0u);
}

TEST(HapticLoop, AbsentDeviceIsZeroedNotFaulted) {
  auto model = testing::ball_model();
  ScriptedDevice d;
  const Pose p = testing::press_pose(2.0);
  d.script = {{DeviceStatus::Ok, p},     {DeviceStatus::Absent, p}, {DeviceStatus::Absent, p},
              {DeviceStatus::NoData, p}, {DeviceStatus::Ok, p},     {DeviceStatus::Absent, p},
              {DeviceStatus::Ok, p}};
  d.writes.reserve(64);
  d.write_after_read.reserve(64);
  HapticLoop loop(model, d, quiet_config());
  std::vector<DeviceState> states;
  for (int n = 0; n < 7; ++n) {
    loop.step(n * kPeriod, n * kPeriod);
    states.push_back(loop.device_state());
  }
  std::vector<TickRecord> r;
  std::vector<DeviceState> published;
  while (const Snapshot* s = loop.net_ring().front()) {
    r.push_back(s->tick);
    published.push_back(s->device_state);
    loop.net_ring().pop();
  }
  ASSERT_EQ(r.size(), 7u);
  constexpr std::uint32_t kAbsent = kZeroDeviceAbsent | kZeroNoPose;  // and no pose while gone
  const std::uint32_t expected[] = {0, kAbsent, kAbsent, kZeroNoPose, 0, kAbsent, 0};
  for (int n = 0; n < 7; ++n) {
    EXPECT_EQ(r[n].fault, expected[n]) << n;
    const bool absent = expected[n] == kAbsent;
    EXPECT_EQ(published[n], absent ? DeviceState::Absent : DeviceState::Present) << n;
    EXPECT_EQ(states[n], published[n]) << n;
    if (expected[n]) {
      EXPECT_EQ(r[n].force, Vec3d{}) << n;
    }
  }
  // The tick that found the device absent (the second read) wrote zero, and nothing else.
  int writes_in_absent_tick = 0;
  for (std::size_t i = 0; i < d.writes.size(); ++i)
    if (d.write_after_read[i] == 2) {
      ++writes_in_absent_tick;
      EXPECT_EQ(d.writes[i].force, Vec3d{});
    }
  EXPECT_GE(writes_in_absent_tick, 1);
  const LoopStats stats = loop.stats();
  EXPECT_EQ(stats.faults, 0u);
  EXPECT_EQ(stats.absent_events, 2u);
}

TEST(HapticLoop, SilentDeviceTimesOutAfterTheBound) {
  auto model = testing::ball_model();
  ScriptedDevice d;
  d.script = {{DeviceStatus::Ok, testing::press_pose(2.0)}, {DeviceStatus::NoData, {}}};
  d.writes.reserve(64);
  d.write_after_read.reserve(64);
  HapticLoop loop(model, d, quiet_config());  // device timeout 10 ms
  for (int n = 0; n <= 12; ++n) loop.step(n * kPeriod, n * kPeriod);
  const std::vector<TickRecord> r = drain(loop);
  for (int n = 0; n <= 10; ++n) EXPECT_EQ(r[n].fault, 0u) << n;  // the last pose is held
  EXPECT_EQ(r[11].fault, kFaultDeviceTimeout);
  EXPECT_EQ(r[12].fault, kFaultDeviceTimeout);
  EXPECT_EQ(r[5].pose.position, testing::press_pose(2.0).position);
}

TEST(HapticLoop, NoPoseYetAndPauseGiveZeroWithoutFault) {
  auto model = testing::ball_model();
  ScriptedDevice d;
  d.script = {{DeviceStatus::NoData, {}}, {DeviceStatus::Ok, testing::press_pose(2.0)}};
  d.writes.reserve(64);
  d.write_after_read.reserve(64);
  HapticLoop loop(model, d, quiet_config());
  loop.step(0, 0);
  loop.step(kPeriod, kPeriod);
  loop.set_paused(true);
  loop.step(2 * kPeriod, 2 * kPeriod);
  loop.set_paused(false);
  loop.step(3 * kPeriod, 3 * kPeriod);
  const std::vector<TickRecord> r = drain(loop);
  EXPECT_EQ(r[0].fault, kZeroNoPose);
  EXPECT_EQ(r[1].fault, 0u);
  EXPECT_EQ(r[2].fault, kZeroPaused);
  EXPECT_EQ(r[2].force, Vec3d{});
  EXPECT_EQ(r[3].fault, 0u);
  EXPECT_EQ(loop.stats().faults, 0u);
}

TEST(HapticLoop, FinishedDeviceStopsTheLoop) {
  auto model = testing::ball_model();
  ScriptedDevice d;
  d.script = {{DeviceStatus::Ok, testing::press_pose(1.0)}, {DeviceStatus::Finished, {}}};
  d.writes.reserve(64);
  d.write_after_read.reserve(64);
  HapticLoop loop(model, d, quiet_config());
  loop.step(0, 0);
  loop.step(kPeriod, kPeriod);
  EXPECT_TRUE(loop.finished());
  EXPECT_EQ(d.writes.back().force, Vec3d{});
  EXPECT_EQ(drain(loop).size(), 1u);
}

TEST(HapticLoop, SwappedModelTakesEffectAtTheNextTick) {
  auto model = testing::ball_model("finger:7");
  ScriptedDevice d = pressing_device(4);
  HapticLoop loop(model, d, quiet_config());
  loop.step(0, 0);
  auto bigger = std::make_shared<const Model>(model->fields_ptr(), parse_tool("finger:19"));
  loop.swap_model(bigger);
  EXPECT_EQ(loop.model(), bigger);
  loop.step(kPeriod, kPeriod);
  std::vector<std::uint32_t> points;
  while (const Snapshot* s = loop.net_ring().front()) {
    points.push_back(s->contact_points);
    loop.net_ring().pop();
  }
  EXPECT_EQ(points, (std::vector<std::uint32_t>{7, 19}));
  // The new model's force is a fresh State's.
  State fresh = make_state(*bigger);
  tick(*bigger, fresh, d.script[1].pose);
  EXPECT_EQ(d.writes[1].force, fresh.f_device);
}

TEST(HapticLoop, RecordingStartsFromAFreshState) {
  auto model = testing::ball_model();
  ScriptedDevice d = pressing_device(10);
  HapticLoop loop(model, d, quiet_config());
  for (int n = 0; n < 5; ++n) loop.step(n * kPeriod, n * kPeriod);
  const std::uint64_t first = loop.set_recording(true);
  EXPECT_EQ(first, 5u);
  for (int n = 5; n < 10; ++n) loop.step(n * kPeriod, n * kPeriod);
  loop.set_recording(false);
  std::vector<TickRecord> recorded;
  while (const Snapshot* s = loop.record_ring().front()) {
    recorded.push_back(s->tick);
    loop.record_ring().pop();
  }
  ASSERT_EQ(recorded.size(), 5u);
  EXPECT_EQ(recorded[0].seq, 5u);
  State fresh = make_state(*model);
  for (int n = 5; n < 10; ++n) {
    tick(*model, fresh, d.script[n].pose);
    EXPECT_EQ(recorded[n - 5].force, fresh.f_device) << n;
  }
}

// The real-time path never touches the heap: ticks in contact, faults, pause, a model swap taken
// over and a recording switched on, with a device profile.
TEST(HapticLoop, StepNeverAllocates) {
  auto model = testing::ball_model("finger:37");
  ScriptedDevice d = pressing_device(200);
  d.script[50].status = DeviceStatus::Timeout;
  LoopConfig c = quiet_config();
  c.profile = &device_profile("phantom-premium");
  HapticLoop loop(model, d, c);
  loop.step(0, 0);  // first tick outside the count
  auto other = std::make_shared<const Model>(model->fields_ptr(), parse_tool("finger:19"));
  loop.swap_model(other);
  loop.set_recording(true);
  loop.net_signal().attach(false);  // the network thread's eventfd, written every tick
  g_allocations = 0;
  g_count_allocations = true;
  for (std::int64_t n = 1; n < 200; ++n) {
    if (n == 100) loop.set_paused(true);
    if (n == 110) loop.set_paused(false);
    loop.step(n * kPeriod, n * kPeriod + (n == 150 ? 9'000'000 : 0));
  }
  g_count_allocations = false;
  EXPECT_EQ(g_allocations.load(), 0);
  const LoopStats s = loop.stats();
  EXPECT_EQ(s.ticks, 200u);
  EXPECT_EQ(s.faults, 2u);  // the device timeout and the late tick
  EXPECT_EQ(s.record_published, 199u);
  // every snapshot published was signalled, without allocating
  EXPECT_EQ(s.net_signals, 199u);
  EXPECT_EQ(loop.net_signal().consume(), 199u);
}

// Issue 41: while the network thread waits and no client is due a frame, the loop hands its
// snapshots over without one eventfd write (a system call a tick before); a tick a client is due
// wakes it, and so does the device going or coming back (Stats at once).
TEST(HapticLoop, WakesTheNetworkThreadOnlyForTicksAClientIsDue) {
  auto model = testing::ball_model();
  ScriptedDevice d = pressing_device(300);
  d.script[285].status = DeviceStatus::Absent;  // unplugged for one tick
  HapticLoop loop(model, d, quiet_config());
  WakeSignal& signal = loop.net_signal();
  signal.attach(true);                    // coalescing, as palpd's network thread
  signal.want_from(WakeSignal::kNobody);  // nobody connected
  std::vector<std::int64_t> woken;
  for (std::int64_t n = 0; n < 300; ++n) {
    if (n == 200) signal.want_from(250 * kPeriod);  // a 100 Hz client's first frame
    signal.arm();                                   // the network thread waits
    loop.step(n * kPeriod, n * kPeriod);
    if (signal.consume() > 0) {  // woken: it drains and says when its client is due next
      woken.push_back(n);
      if (n >= 250) signal.want_from((n / 10 + 1) * 10 * kPeriod);
    }
    drain(loop);
  }
  EXPECT_EQ(woken, (std::vector<std::int64_t>{250, 260, 270, 280, 285, 286, 290}));
  EXPECT_EQ(loop.stats().net_signals, woken.size());
}

// The rates palpd is tested at, on the loop's own thread; only counts are checked.
TEST(HapticLoop, RunsFrom500HzTo10kHz) {
  for (const double rate : {500.0, 1000.0, 10000.0}) {
    auto model = testing::ball_model();
    ScriptedDevice d;
    d.script = {{DeviceStatus::Ok, testing::press_pose(2.0)}};
    d.writes.reserve(1 << 20);
    d.write_after_read.reserve(1 << 20);
    LoopConfig c = quiet_config();
    c.rate_hz = rate;
    c.watchdog_late_s = 0;
    HapticLoop loop(model, d, c);
    EXPECT_EQ(loop.period_ns(), static_cast<std::int64_t>(1e9 / rate));
    loop.start();
    while (loop.stats().ticks < 50) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    loop.stop();
    const LoopStats s = loop.stats();
    std::uint64_t histogram = 0;
    for (std::uint64_t b : s.jitter) histogram += b;
    EXPECT_EQ(histogram, s.ticks) << rate;
    EXPECT_EQ(s.net_published + s.net_dropped, s.ticks) << rate;
    EXPECT_EQ(s.faults, 0u) << rate;
  }
}

TEST(HapticLoop, ThreadTicksAndStopsWithZeroForce) {
  auto model = testing::ball_model();
  ScriptedDevice d;
  d.script = {{DeviceStatus::Ok, testing::press_pose(2.0)}};
  d.writes.reserve(1 << 20);
  d.write_after_read.reserve(1 << 20);
  LoopConfig c = quiet_config();
  c.rate_hz = 2000;
  c.watchdog_late_s = 0;  // a busy test machine must not fail this test
  HapticLoop loop(model, d, c);
  loop.start();
  EXPECT_NE(loop.realtime_report().find("not requested"), std::string::npos);
  while (loop.stats().ticks < 20) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  loop.stop();
  const LoopStats s = loop.stats();
  EXPECT_GE(s.ticks, 20u);
  std::uint64_t histogram = 0;
  for (std::uint64_t b : s.jitter) histogram += b;
  EXPECT_EQ(histogram, s.ticks);
  EXPECT_EQ(d.writes.back().force, Vec3d{});
  EXPECT_GT(norm(d.writes.front().force), 0.0);
}

}  // namespace
}  // namespace palp::rt
