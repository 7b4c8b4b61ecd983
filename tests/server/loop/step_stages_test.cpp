// The pure stages of a tick (loop/step_stages.hpp): the watchdog's bound, what each device answer
// means for the force, when a re-centre may happen and where it moves the home, the state a
// snapshot tells and the zero bits of an idle tick.
#include "loop/step_stages.hpp"

#include <gtest/gtest.h>

namespace palp::rt {
namespace {

TEST(TickStages, WatchdogFaultsOnlyPastItsBoundAndNotWhenOff) {
  EXPECT_EQ(watchdog_bits(5'000'000, 5'000'000), kFaultNone);  // at the bound: still on time
  EXPECT_EQ(watchdog_bits(5'000'001, 5'000'000), kFaultDeadline);
  EXPECT_EQ(watchdog_bits(-1'000, 5'000'000), kFaultNone);  // early
  EXPECT_EQ(watchdog_bits(1'000'000'000, 0), kFaultNone);   // 0: off
}

TEST(TickStages, EachDeviceAnswerHasItsBits) {
  constexpr std::int64_t kTimeout = 100'000'000;
  EXPECT_EQ(read_bits(DeviceStatus::Ok, 0, false, 0, kTimeout), kFaultNone);
  // a replay's recorded zero-force tick comes back as its bits
  EXPECT_EQ(read_bits(DeviceStatus::Ok, kZeroPaused, true, 0, kTimeout), kZeroPaused);
  EXPECT_EQ(read_bits(DeviceStatus::Timeout, 0, true, 0, kTimeout), kFaultDeviceTimeout);
  EXPECT_EQ(read_bits(DeviceStatus::Disconnected, 0, true, 0, kTimeout), kFaultDeviceLost);
  EXPECT_EQ(read_bits(DeviceStatus::Error, 0, true, 0, kTimeout), kFaultDeviceLost);
  EXPECT_EQ(read_bits(DeviceStatus::Absent, 0, true, 0, kTimeout), kZeroDeviceAbsent);
  EXPECT_EQ(read_bits(DeviceStatus::Finished, 0, true, 0, kTimeout), kFaultNone);
}

TEST(TickStages, NoDataTimesOutOnlyAfterAPoseAndPastTheTimeout) {
  constexpr std::int64_t kTimeout = 100'000'000;
  EXPECT_EQ(read_bits(DeviceStatus::NoData, 0, true, kTimeout, kTimeout), kFaultNone);
  EXPECT_EQ(read_bits(DeviceStatus::NoData, 0, true, kTimeout + 1, kTimeout), kFaultDeviceTimeout);
  // no pose yet: waiting for the first one is not a timeout (kZeroNoPose says it)
  EXPECT_EQ(read_bits(DeviceStatus::NoData, 0, false, 10 * kTimeout, kTimeout), kFaultNone);
  EXPECT_EQ(read_bits(DeviceStatus::NoData, 0, true, 10 * kTimeout, 0), kFaultNone);  // off
}

TEST(TickStages, ARecentreWaitsForAPoseNoContactAndARegistration) {
  EXPECT_TRUE(may_recentre(true, true, 0, false));
  EXPECT_FALSE(may_recentre(false, true, 0, false));  // not asked
  EXPECT_FALSE(may_recentre(true, false, 0, false));  // no pose
  EXPECT_FALSE(may_recentre(true, true, 3, false));   // in contact: the force would step
  EXPECT_FALSE(may_recentre(true, true, 0, true));    // identity: nothing to move
}

TEST(TickStages, TheRecentredHomeMapsTheDeviceOntoTheConfiguredHome) {
  Registration r;
  r.rotation = {0, -1, 0, 1, 0, 0, 0, 0, 1};  // 90 degrees about z
  r.scale = 2.0;
  r.home = {7, 7, 7};  // where an earlier re-centre left it: not used
  const Vec3d configured{10, 20, 30}, device{1, 2, 3};
  r.home = recentred_home(r, configured, device);
  const Vec3d there = point_to_scene(r, device);
  EXPECT_NEAR(there.x, configured.x, 1e-12);
  EXPECT_NEAR(there.y, configured.y, 1e-12);
  EXPECT_NEAR(there.z, configured.z, 1e-12);
}

TEST(TickStages, AnAbsentReadShowsAbsentEvenBeforeTheDeviceSaysSo) {
  EXPECT_EQ(presence(kZeroDeviceAbsent, DeviceState::Present), DeviceState::Absent);
  EXPECT_EQ(presence(kZeroDeviceAbsent, DeviceState::Fault), DeviceState::Fault);
  EXPECT_EQ(presence(kFaultDeviceLost, DeviceState::Present), DeviceState::Present);
  EXPECT_EQ(presence(0, DeviceState::Absent), DeviceState::Absent);
}

TEST(TickStages, IdleBits) {
  EXPECT_EQ(idle_bits(true, false), kFaultNone);
  EXPECT_EQ(idle_bits(false, false), kZeroNoPose);
  EXPECT_EQ(idle_bits(true, true), kZeroPaused);
  EXPECT_EQ(idle_bits(false, true), kZeroNoPose | kZeroPaused);
  EXPECT_EQ(idle_bits(false, true) & kFaultMask, 0u);  // neither is a fault
}

}  // namespace
}  // namespace palp::rt
