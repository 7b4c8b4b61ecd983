// sim and sim:FILE: rows at their timestamps, looping; the built-in path; make_device.
#include <gtest/gtest.h>

#include "base/errors.hpp"
#include "devices/device.hpp"
#include "support/palpd_test_util.hpp"

namespace palp::rt {
namespace {

Trajectory three_rows() {
  Trajectory t;
  for (int i = 0; i < 3; ++i) {
    TrajectorySample s;
    s.t = 10.0 + 0.5 * i;  // rows at 10, 10.5, 11 s: period 1.5 s
    s.pose.position = {double(i), 0.0, 0.0};
    t.push_back(s);
  }
  return t;
}

double x_at(SimDevice& d, double seconds) {
  DeviceSample s;
  EXPECT_EQ(d.read(static_cast<std::int64_t>(seconds * 1e9) + 5'000'000'000, s), DeviceStatus::Ok);
  return s.pose.position.x;
}

TEST(SimDevice, PlaysRowsAtTheirTimestampsAndLoops) {
  SimDevice d(three_rows());
  ASSERT_EQ(d.configure({}), DeviceStatus::Ok);
  ASSERT_EQ(d.activate(), DeviceStatus::Ok);
  EXPECT_DOUBLE_EQ(d.period_s(), 1.5);
  EXPECT_EQ(x_at(d, 0.0), 0.0);  // the first read starts the clock
  EXPECT_EQ(x_at(d, 0.49), 0.0);
  EXPECT_EQ(x_at(d, 0.5), 1.0);
  EXPECT_EQ(x_at(d, 1.2), 2.0);
  EXPECT_EQ(x_at(d, 1.5), 0.0);  // second lap
  EXPECT_EQ(x_at(d, 2.0), 1.0);
  EXPECT_EQ(x_at(d, 4.6), 0.0);  // lap 4 (skipping laps is fine)
  EXPECT_EQ(x_at(d, 4.6 + 0.5), 1.0);
}

TEST(SimDevice, RecordsWhatItIsWritten) {
  SimDevice d(three_rows());
  d.configure({});
  d.activate();
  EXPECT_EQ(d.write({{1, 2, 3}, {}}), DeviceStatus::Ok);
  EXPECT_EQ(d.last_command().force, (Vec3d{1, 2, 3}));
  EXPECT_EQ(d.writes(), 1u);
  d.deactivate();
  DeviceSample s;
  EXPECT_EQ(d.read(0, s), DeviceStatus::Disconnected);
}

TEST(SimDevice, BuiltInPathTouchesTheScene) {
  DeviceConfig config;
  config.fields = testing::ball_fields();
  config.tool = parse_tool("finger:7");
  SimDevice d;
  ASSERT_EQ(d.configure(config), DeviceStatus::Ok) << d.last_error();
  ASSERT_GT(d.trajectory().size(), 100u);
  // The ball is no torso: the fallback press-and-hold comes down on it from above and lifts off.
  const Model model(config.fields, config.tool);
  State state = make_state(model);
  int touching = 0;
  for (const TrajectorySample& s : d.trajectory()) {
    tick(model, state, s.pose);
    touching += state.n_contact > 0;
  }
  EXPECT_GT(touching, 100);
  tick(model, state, d.trajectory().front().pose);
  EXPECT_EQ(state.n_contact, 0);
  tick(model, state, d.trajectory().back().pose);
  EXPECT_EQ(state.n_contact, 0);
}

TEST(SimDevice, BuiltInPathNeedsAScene) {
  SimDevice d;
  EXPECT_EQ(d.configure({}), DeviceStatus::Error);
  EXPECT_FALSE(d.last_error().empty());
}

TEST(SimDevice, ItsPathIsKnownBeforeItRuns) {
  const auto fields = testing::ball_fields();
  const Tool tool = parse_tool("finger:7");
  const auto from_file = SimDevice(three_rows()).scripted_path(*fields, tool);
  ASSERT_TRUE(from_file);
  ASSERT_EQ(from_file->size(), 3u);
  EXPECT_EQ((*from_file)[2].pose.position.x, 2.0);
  const auto built_in = SimDevice().scripted_path(*fields, tool);
  ASSERT_TRUE(built_in);
  EXPECT_EQ(built_in->size(), builtin_palpation_path(*fields, tool).size());
}

TEST(MakeDevice, CapabilitiesAreTheDevicesOwn) {
  // palpd places, limits and homes a device by these, never by its kind's name.
  for (const char* spec : {"sim", "remote"}) {
    const auto d = make_device(spec);
    EXPECT_FALSE(d->drives_a_hand()) << spec;
    EXPECT_FALSE(d->takes_home()) << spec;
    EXPECT_TRUE(d->own_profile().empty()) << spec;
  }
  const auto fields = testing::ball_fields();
  EXPECT_TRUE(make_device("sim")->scripted_path(*fields, parse_tool("finger:1")));
  EXPECT_FALSE(make_device("remote")->scripted_path(*fields, parse_tool("finger:1")));
}

TEST(MakeDevice, KnowsItsDevices) {
  EXPECT_EQ(make_device("sim")->kind(), "sim");
  EXPECT_EQ(make_device("remote")->kind(), "remote");
  EXPECT_THROW(make_device("usb"), UsageError);
  EXPECT_THROW(make_device("sim:"), UsageError);
  EXPECT_THROW(make_device("replay:"), UsageError);
  EXPECT_THROW(make_device("remote:x"), UsageError);
  EXPECT_THROW(make_device("sim:/nonexistent/path.csv"), InputError);
  EXPECT_THROW(make_device("replay:/nonexistent/path.palprec"), InputError);
}

}  // namespace
}  // namespace palp::rt
