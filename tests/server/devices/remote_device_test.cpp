// remote: poses from the network thread, NoData between them, Absent when they stop (one absent
// period, not a fault per tick).
#include <gtest/gtest.h>

#include <thread>

#include "devices/device.hpp"

namespace palp::rt {
namespace {

TEST(RemoteDevice, NoDataUntilAPoseThenHoldsThenAbsent) {
  RemoteDevice d;
  DeviceConfig c;
  c.timeout_s = 0.1;
  ASSERT_EQ(d.configure(c), DeviceStatus::Ok);
  ASSERT_EQ(d.activate(), DeviceStatus::Ok);
  DeviceSample s;
  EXPECT_EQ(d.read(0, s), DeviceStatus::NoData);
  Pose p;
  p.position = {1, 2, 3};
  d.submit(p, 1'000'000'000);
  EXPECT_EQ(d.read(1'001'000'000, s), DeviceStatus::Ok);
  EXPECT_EQ(s.pose.position, p.position);
  EXPECT_EQ(d.read(1'050'000'000, s), DeviceStatus::NoData);
  EXPECT_EQ(d.read(1'100'000'000, s), DeviceStatus::NoData);
  EXPECT_EQ(d.state(), DeviceState::Present);
  EXPECT_EQ(d.read(1'100'000'001, s), DeviceStatus::Absent);
  EXPECT_EQ(d.state(), DeviceState::Absent);
  EXPECT_EQ(d.read(1'150'000'000, s), DeviceStatus::Absent);  // stays absent, quietly
  p.position = {4, 5, 6};
  d.submit(p, 1'200'000'000);
  EXPECT_EQ(d.read(1'200'000'000, s), DeviceStatus::Ok);
  EXPECT_EQ(s.pose.position, p.position);
  EXPECT_EQ(d.state(), DeviceState::Present);
}

TEST(RemoteDevice, PassesTheLastForceBack) {
  RemoteDevice d;
  d.configure({});
  d.activate();
  EXPECT_EQ(d.last_command().force, Vec3d{});
  d.write({{1, 0, 0}, {}});
  d.write({{2, 0, 0}, {}});
  EXPECT_EQ(d.last_command().force, (Vec3d{2, 0, 0}));
  EXPECT_EQ(d.last_command().force, (Vec3d{2, 0, 0}));
}

TEST(RemoteDevice, RefusesANonPositiveTimeout) {
  RemoteDevice d;
  DeviceConfig c;
  c.timeout_s = 0.0;
  EXPECT_EQ(d.configure(c), DeviceStatus::Error);
}

TEST(RemoteDevice, ConcurrentPosesArriveWhole) {
  RemoteDevice d;
  d.configure({});
  d.activate();
  std::thread network([&] {
    for (int i = 1; i <= 100000; ++i) {
      Pose p;
      p.position = {double(i), double(-i), double(2 * i)};
      d.submit(p, 0);
    }
  });
  double last = 0;
  bool whole = true;
  while (last < 100000) {
    DeviceSample s;
    if (d.read(0, s) != DeviceStatus::Ok) continue;
    const Vec3d x = s.pose.position;
    if (x.y != -x.x || x.z != 2 * x.x || x.x < last) whole = false;
    last = x.x;
  }
  network.join();
  EXPECT_TRUE(whole);
}

}  // namespace
}  // namespace palp::rt
