// `--device spacemouse` (server/devices/spacemouse_device.cpp): HID report parsing and the
// deflection-to-pose mapping with exact numbers (no USB), the spec parser, and the device against
// SpaceMice emulated in process by umockdev (tests/usb_emulator): enumeration by VID:PID among
// other HID devices, claim, reports streamed at rate, short / malformed / unknown reports counted
// and ignored, the buttons, a non-HID device refused, unplug mid-stream under a running HapticLoop
// (loop alive, device absent, force zero, clients told) and replug.
// The emulated tests run under umockdev-wrapper and skip without it; the others always run.
#include "devices/spacemouse_device.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <thread>

#include "base/errors.hpp"
#include "loop/haptic_loop.hpp"
#include "net/server.hpp"
#include "support/net_test_client.hpp"
#include "support/palpd_test_util.hpp"
#include "support/served_ball.hpp"
#include "support/usb_emulator.hpp"

namespace palp::rt {
namespace {

using spacemouse::Axes;
using spacemouse::MapperSettings;
using spacemouse::Mode;
using spacemouse::PoseMapper;
using spacemouse::ReportKind;
using usbemu::DeviceSpec;
using usbemu::EmulatedUsbDevice;
using usbemu::UsbTestbed;
using usbemu::wait_until;

constexpr double kWait = 20.0;  // generous: a loaded 2-core machine
constexpr double kDeg = std::numbers::pi / 180.0;

std::vector<std::uint8_t> report(std::uint8_t id, std::vector<std::int16_t> values) {
  std::vector<std::uint8_t> bytes{id};
  for (std::int16_t v : values) {
    bytes.push_back(static_cast<std::uint8_t>(static_cast<std::uint16_t>(v) & 0xff));
    bytes.push_back(static_cast<std::uint8_t>(static_cast<std::uint16_t>(v) >> 8));
  }
  return bytes;
}

ReportKind parse(const std::vector<std::uint8_t>& bytes, Axes& axes, std::uint32_t& buttons) {
  return spacemouse::parse_report(bytes.data(), bytes.size(), axes, buttons);
}

void expect_near(const Vec3d& a, const Vec3d& b, double tolerance = 1e-9) {
  EXPECT_NEAR(a.x, b.x, tolerance);
  EXPECT_NEAR(a.y, b.y, tolerance);
  EXPECT_NEAR(a.z, b.z, tolerance);
}

void expect_same_rotation(const Quat& a, const Quat& b, double tolerance = 1e-9) {
  const double sign = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z < 0 ? -1.0 : 1.0;
  EXPECT_NEAR(a.w, sign * b.w, tolerance);
  EXPECT_NEAR(a.x, sign * b.x, tolerance);
  EXPECT_NEAR(a.y, sign * b.y, tolerance);
  EXPECT_NEAR(a.z, sign * b.z, tolerance);
}

// ----------------------------------------------------------------------------------------------
// Reports

TEST(SpaceMouseReport, ParsesTranslationRotationSixAxesAndButtons) {
  Axes axes{};
  std::uint32_t buttons = 0;
  EXPECT_EQ(parse(report(1, {10, -20, 350}), axes, buttons), ReportKind::Translation);
  EXPECT_EQ(axes, (Axes{10, -20, 350, 0, 0, 0}));
  EXPECT_EQ(parse(report(2, {-512, 7, -1}), axes, buttons), ReportKind::Rotation);
  EXPECT_EQ(axes, (Axes{10, -20, 350, -512, 7, -1}));  // translation kept
  EXPECT_EQ(parse(report(1, {1, 2, 3, 4, 5, 6}), axes, buttons), ReportKind::SixAxes);
  EXPECT_EQ(axes, (Axes{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(parse({3, 0x03}, axes, buttons), ReportKind::Buttons);
  EXPECT_EQ(buttons, 3u);
  EXPECT_EQ(parse({3, 0x00, 0x01}, axes, buttons), ReportKind::Buttons);
  EXPECT_EQ(buttons, 0x100u);
  EXPECT_EQ(axes, (Axes{1, 2, 3, 4, 5, 6}));  // buttons leave the axes alone
}

TEST(SpaceMouseReport, ShortMalformedAndUnknownLeaveTheStateAlone) {
  const Axes before{1, 2, 3, 4, 5, 6};
  Axes axes = before;
  std::uint32_t buttons = 9;
  EXPECT_EQ(spacemouse::parse_report(nullptr, 0, axes, buttons), ReportKind::Short);
  EXPECT_EQ(parse({1, 0, 0, 0}, axes, buttons), ReportKind::Short);
  EXPECT_EQ(parse({2, 0, 0, 0, 0, 0}, axes, buttons), ReportKind::Short);
  EXPECT_EQ(parse({3}, axes, buttons), ReportKind::Short);
  EXPECT_EQ(parse(report(1, {1, 1, 1, 1}), axes, buttons), ReportKind::Malformed);  // 8 bytes
  EXPECT_EQ(parse(report(1, {1, 2049, 1}), axes, buttons), ReportKind::Malformed);
  EXPECT_EQ(parse(report(2, {-2049, 0, 0}), axes, buttons), ReportKind::Malformed);
  EXPECT_EQ(parse(report(1, {0, 0, 0, 0, 0, -32768}), axes, buttons), ReportKind::Malformed);
  EXPECT_EQ(parse({0x17, 0x64}, axes, buttons), ReportKind::Unknown);  // battery
  EXPECT_EQ(axes, before);
  EXPECT_EQ(buttons, 9u);
}

TEST(SpaceMouseReport, KnownIdsMatchTheUdevRules) {
  EXPECT_TRUE(spacemouse::is_known({0x046d, 0xc626}));   // SpaceNavigator
  EXPECT_TRUE(spacemouse::is_known({0x256f, 0xc635}));   // SpaceMouse Compact
  EXPECT_FALSE(spacemouse::is_known({0x046d, 0xc52b}));  // a Logitech receiver
  EXPECT_EQ(spacemouse::kKnownIds.size(), 18u);
}

// ----------------------------------------------------------------------------------------------
// Mapping

Pose at(double x, double y, double z, Quat q = {}) {
  Pose p;
  p.position = {x, y, z};
  p.orientation = q;
  return p;
}

TEST(SpaceMouseMapper, DeadbandAndSaturation) {
  const PoseMapper mapper;  // deadband 15, full scale 350
  EXPECT_EQ(mapper.shaped(0), 0.0);
  EXPECT_EQ(mapper.shaped(15), 0.0);
  EXPECT_EQ(mapper.shaped(-15), 0.0);
  EXPECT_EQ(mapper.shaped(16), 1.0);
  EXPECT_EQ(mapper.shaped(-115), -100.0);
  EXPECT_EQ(mapper.shaped(350), 335.0);
  EXPECT_EQ(mapper.shaped(512), 335.0);
}

TEST(SpaceMouseMapper, RateModeIntegratesInTheUserFrame) {
  PoseMapper mapper(MapperSettings{}, at(0, 0, 100));
  // Cap right (+x), toward the user (+y HID = -y user) and down (+z HID = press, -z user):
  // 100 counts past the deadband at 0.1 mm/s per count for 1 s = 10 mm on each axis.
  const Axes axes{115, 115, 115, 0, 0, 0};
  for (int i = 0; i < 100; ++i) mapper.update(axes, 0.01);
  expect_near(mapper.pose().position, {10.0, -10.0, 90.0});
  expect_same_rotation(mapper.pose().orientation, Quat{});
  // At rest it stays.
  mapper.update(Axes{5, -5, 14, 0, 0, 0}, 1.0);
  expect_near(mapper.pose().position, {10.0, -10.0, 90.0});
  mapper.go_home();
  expect_near(mapper.pose().position, {0.0, 0.0, 100.0});
}

TEST(SpaceMouseMapper, PushingDownPressesAlongTheHomeNormal) {
  // Home with tool +z = scene -y (90° about x): the skin faces -y, so pressing moves +y.
  const Quat q = axis_angle({1, 0, 0}, 90 * kDeg);
  PoseMapper mapper(MapperSettings{}, at(5, -50, 0, q));
  for (int i = 0; i < 10; ++i) mapper.update(Axes{0, 0, 65, 0, 0, 0}, 0.1);  // 50 counts, 1 s
  expect_near(mapper.pose().position, {5.0, -45.0, 0.0});
  expect_same_rotation(mapper.pose().orientation, q);
}

TEST(SpaceMouseMapper, WorkspaceBoxAndTiltLimit) {
  PoseMapper mapper(MapperSettings{}, at(0, 0, 0));
  for (int i = 0; i < 1000; ++i) mapper.update(Axes{-350, -350, 350, 350, 0, 0}, 0.05);
  // 50 s at full deflection: the box stops it (lateral 60, 40 below home) ...
  expect_near(mapper.pose().position, {-60.0, 60.0, -40.0});
  // ... and the tilt about x stops at 45°.
  expect_same_rotation(mapper.pose().orientation, axis_angle({1, 0, 0}, 45 * kDeg));
  for (int i = 0; i < 1000; ++i) mapper.update(Axes{0, 0, -350, 0, 0, 0}, 0.05);
  EXPECT_NEAR(mapper.pose().position.z, 40.0, 1e-9);  // 40 above
}

TEST(SpaceMouseMapper, RateModeTwistTurnsAboutTheToolAxis) {
  PoseMapper mapper(MapperSettings{}, at(0, 0, 0));
  // Twisting the cap clockwise seen from above is +rz in HID (z down): -rz in the user frame.
  for (int i = 0; i < 100; ++i) mapper.update(Axes{0, 0, 0, 0, 0, 115}, 0.01);
  expect_same_rotation(mapper.pose().orientation, axis_angle({0, 0, 1}, -10 * kDeg));
  MapperSettings no_rotation;
  no_rotation.rotation = false;
  PoseMapper fixed(no_rotation, at(0, 0, 0));
  fixed.update(Axes{0, 0, 0, 300, 300, 300}, 1.0);
  expect_same_rotation(fixed.pose().orientation, Quat{});
}

TEST(SpaceMouseMapper, PositionModeIsAnOffsetFromHome) {
  MapperSettings settings;
  settings.mode = Mode::Position;
  PoseMapper mapper(settings, at(1, 2, 3));
  mapper.update(Axes{-115, 0, 215, 0, 115, 0}, 123.0);  // dt does not matter
  // 0.05 mm per count: x -5 mm, z -10 mm; 0.05° per count: -5° about y (HID +ry = user -y).
  expect_near(mapper.pose().position, {-4.0, 2.0, -7.0});
  expect_same_rotation(mapper.pose().orientation, axis_angle({0, 1, 0}, -5 * kDeg));
  mapper.update(Axes{}, 0.0);  // let go: home
  expect_near(mapper.pose().position, {1.0, 2.0, 3.0});
}

TEST(SpaceMouseMapper, PressLockHoldsTheDepth) {
  PoseMapper rate(MapperSettings{}, at(0, 0, 0));
  rate.update(Axes{0, 0, 115, 0, 0, 0}, 0.05);  // 0.5 mm down
  rate.toggle_press_lock();
  EXPECT_TRUE(rate.press_lock());
  rate.update(Axes{115, 0, 350, 0, 0, 0}, 0.05);  // pressing harder does nothing; sliding does
  expect_near(rate.pose().position, {0.5, 0.0, -0.5});
  rate.toggle_press_lock();
  rate.update(Axes{0, 0, 115, 0, 0, 0}, 0.05);
  expect_near(rate.pose().position, {0.5, 0.0, -1.0});

  MapperSettings settings;
  settings.mode = Mode::Position;
  PoseMapper position(settings, at(0, 0, 0));
  position.update(Axes{0, 0, 115, 0, 0, 0}, 0.0);  // 5 mm down
  position.toggle_press_lock();
  position.update(Axes{215, 0, 0, 0, 0, 0}, 0.0);  // let go vertically, slide 10 mm
  expect_near(position.pose().position, {10.0, 0.0, -5.0});
  position.go_home();  // also releases the lock
  EXPECT_FALSE(position.press_lock());
  position.update(Axes{}, 0.0);
  expect_near(position.pose().position, {0.0, 0.0, 0.0});
}

TEST(SpaceMouseMapper, RejectsUnusableSettings) {
  MapperSettings s;
  s.full_scale_counts = 10.0;  // below the deadband
  EXPECT_THROW(PoseMapper{s}, UsageError);
  s = MapperSettings{};
  s.box_below_mm = 0.0;
  EXPECT_THROW(PoseMapper{s}, UsageError);
  s = MapperSettings{};
  s.rate_mm_s_per_count = std::nan("");
  EXPECT_THROW(PoseMapper{s}, UsageError);
}

TEST(SpaceMouseMapper, HomeIsAboveTheSceneWhereTheBuiltInPathStarts) {
  // sim's built-in path starts with the pad 2 mm above the skin, tool +z along the outward
  // normal; the SpaceMouse's home is that pose lifted 10 mm along tool +z.
  const auto fields = testing::ball_fields();
  const Tool tool = parse_tool("finger:7");
  const Pose start = builtin_palpation_path(*fields, tool).front().pose;
  const Pose home = spacemouse::home_pose(*fields, tool, 10.0);
  const Vec3d normal = rotate(start.orientation, Vec3d{0, 0, 1});
  expect_near(home.position, start.position + 10.0 * normal);
  expect_same_rotation(home.orientation, start.orientation);
  // On the ball (radius 20 about (31, 31, 31)) the pad centre, 8 mm below the device point, is
  // then 2 + 10 mm outside the skin.
  const Vec3d pad = home.position - 8.0 * normal;
  EXPECT_NEAR(norm(pad - Vec3d{31, 31, 31}), 32.0, 0.1);
}

// ----------------------------------------------------------------------------------------------
// The device without USB

TEST(SpaceMouseSpec, MakeDeviceParsesModeAndVidPid) {
  auto as_spacemouse = [](const std::unique_ptr<Device>& d) {
    auto* s = dynamic_cast<SpaceMouseDevice*>(d.get());
    EXPECT_NE(s, nullptr);
    return s;
  };
  auto d = make_device("spacemouse");
  EXPECT_EQ(d->kind(), "spacemouse");
  EXPECT_FALSE(d->renders_force());  // SceneInfo.device_renders_force = false
  EXPECT_EQ(as_spacemouse(d)->options().mapper.mode, Mode::Rate);  // the default
  EXPECT_EQ(as_spacemouse(d)->options().ids.size(), 18u);
  d = make_device("spacemouse:position");
  EXPECT_EQ(as_spacemouse(d)->options().mapper.mode, Mode::Position);
  d = make_device("spacemouse:rate:256f:c635");
  EXPECT_EQ(as_spacemouse(d)->options().mapper.mode, Mode::Rate);
  ASSERT_EQ(as_spacemouse(d)->options().ids.size(), 1u);
  EXPECT_EQ(as_spacemouse(d)->options().ids[0], (usb::UsbId{0x256f, 0xc635}));
  d = make_device("spacemouse:046d:c626");
  EXPECT_EQ(as_spacemouse(d)->options().ids[0], (usb::UsbId{0x046d, 0xc626}));
  d = make_device("spacemouse:position:1234:5678");  // an unlisted model may be named
  EXPECT_EQ(as_spacemouse(d)->options().mapper.mode, Mode::Position);
  EXPECT_THROW(make_device("spacemouse:fast"), UsageError);
  EXPECT_THROW(make_device("spacemouse:rate:"), UsageError);
  EXPECT_THROW(make_device("spacemouse:ratex:046d:c626"), UsageError);
  EXPECT_THROW(make_device("spacemouse:046d"), UsageError);
}

TEST(SpaceMouseSpec, ConfigureNeedsASceneOrAHomeAndWriteIsCounted) {
  SpaceMouseDevice bare(SpaceMouseDevice::Options{});
  EXPECT_EQ(bare.configure(DeviceConfig{}), DeviceStatus::Error);
  EXPECT_NE(bare.last_error().find("scene"), std::string::npos) << bare.last_error();
  DeviceSample sample;
  EXPECT_EQ(bare.read(0, sample), DeviceStatus::Disconnected);  // not active
  EXPECT_EQ(bare.write(DeviceCommand{}), DeviceStatus::Disconnected);

  DeviceConfig config;
  config.fields = testing::ball_fields();
  config.tool = parse_tool("finger:1");
  SpaceMouseDevice scene_home(SpaceMouseDevice::Options{});
  EXPECT_EQ(scene_home.configure(config), DeviceStatus::Ok) << scene_home.last_error();
}

// ----------------------------------------------------------------------------------------------
// Emulated SpaceMice

// A SpaceMouse's USB face: interface 0, HID, one interrupt IN endpoint 0x81 (8 ms).
DeviceSpec spacemouse_spec(std::uint16_t vendor, std::uint16_t product,
                           std::uint8_t interface_class = 3) {
  DeviceSpec spec;
  spec.vendor_id = vendor;
  spec.product_id = product;
  spec.interfaces[0].interface_class = interface_class;
  spec.interfaces[0].subclass = 0;
  spec.interfaces[0].protocol = 0;
  if (interface_class == 3)  // HID descriptor 1.11, one report descriptor of 217 bytes
    spec.interfaces[0].class_descriptor = {9, 0x21, 0x11, 0x01, 0, 1, 0x22, 217, 0};
  spec.interfaces[0].endpoints = {{0x81, 0x03, 16, 8}};
  return spec;
}

class SpaceMouseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!UsbTestbed::in_mock_environment()) GTEST_SKIP() << "needs umockdev-wrapper";
    testbed_ = std::make_unique<UsbTestbed>();
  }
  static SpaceMouseDevice::Options options(Mode mode = Mode::Rate) {
    SpaceMouseDevice::Options o;
    o.mapper.mode = mode;
    o.home = at(0, 0, 100);
    return o;
  }
  static LoopConfig loop_config() {
    LoopConfig c;
    c.realtime = false;
    c.watchdog_late_s = 0;  // a loaded CI machine: no deadline faults
    c.device_timeout_s = 1.0;
    return c;
  }
  // Reads until the newest deflection equals `want` (as seen through the position-mode pose).
  static bool wait_for_pose(SpaceMouseDevice& device, const Vec3d& want) {
    DeviceSample sample;
    return wait_until(
        [&] {
          return device.read(0, sample) == DeviceStatus::Ok &&
                 norm(sample.pose.position - want) < 1e-9;
        },
        kWait);
  }
  std::unique_ptr<UsbTestbed> testbed_;
};

TEST_F(SpaceMouseTest, EnumeratesByVidPidClaimsAndStreamsAtRate) {
  EmulatedUsbDevice receiver(*testbed_, spacemouse_spec(0x046d, 0xc52b));  // not a SpaceMouse
  EmulatedUsbDevice mouse(*testbed_, spacemouse_spec(0x046d, 0xc626));     // SpaceNavigator
  receiver.plug();
  mouse.plug();
  // 125 Hz, alternating translation and rotation reports as the older devices send them: the
  // cap pressed down by 115 counts (100 past the deadband), no rotation.
  mouse.start_in_stream(0x81, 125.0, [](std::uint64_t i, std::int64_t) {
    return i % 2 == 0 ? report(1, {0, 0, 115}) : report(2, {0, 0, 0});
  });
  SpaceMouseDevice device(options());  // any known SpaceMouse
  ASSERT_EQ(device.configure(DeviceConfig{}), DeviceStatus::Ok) << device.last_error();
  ASSERT_EQ(device.activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device.state() == DeviceState::Present; }, kWait))
      << device.status_message();
  EXPECT_EQ(mouse.claims(), 1u);
  EXPECT_EQ(receiver.claims(), 0u);
  EXPECT_NE(device.status_message().find("046d:c626"), std::string::npos)
      << device.status_message();
  EXPECT_NE(device.status_message().find("rate mode"), std::string::npos);

  const std::uint64_t before = device.counters().reports;
  std::this_thread::sleep_for(std::chrono::milliseconds(400));  // measures, asserts no timing
  const std::uint64_t streamed = device.counters().reports - before;
  std::printf("0.4 s at 125 Hz: %llu reports parsed\n", static_cast<unsigned long long>(streamed));
  EXPECT_GT(streamed, 0u);

  // Rate mode: 100 reads 10 ms apart (the loop's clock) = 1 s at 10 mm/s down.
  DeviceSample sample;
  std::int64_t now = 1'000'000'000;
  ASSERT_EQ(device.read(now, sample), DeviceStatus::Ok);  // the first read moves nothing
  expect_near(sample.pose.position, {0.0, 0.0, 100.0});
  for (int i = 0; i < 100; ++i) ASSERT_EQ(device.read(now += 10'000'000, sample), DeviceStatus::Ok);
  expect_near(sample.pose.position, {0.0, 0.0, 90.0});
  // A long gap (the loop stalled) integrates at most max_step_s (50 ms): 0.5 mm.
  ASSERT_EQ(device.read(now += 2'000'000'000, sample), DeviceStatus::Ok);
  expect_near(sample.pose.position, {0.0, 0.0, 89.5});

  EXPECT_EQ(device.write(DeviceCommand{{0, 0, 2.5}, {}}), DeviceStatus::Ok);
  EXPECT_EQ(device.counters().writes, 1u);
  EXPECT_EQ(device.last_force(), (Vec3d{0, 0, 2.5}));
  EXPECT_EQ(device.counters().malformed + device.counters().short_reports, 0u);
  ASSERT_EQ(device.deactivate(), DeviceStatus::Ok);
  EXPECT_EQ(device.read(now, sample), DeviceStatus::Disconnected);
}

TEST_F(SpaceMouseTest, NewerDevicesSendAllSixAxesInOneReport) {
  EmulatedUsbDevice mouse(*testbed_, spacemouse_spec(0x256f, 0xc635));
  mouse.plug();
  auto o = options(Mode::Position);
  o.ids = {{0x256f, 0xc635}};
  SpaceMouseDevice device(o);
  ASSERT_EQ(device.configure(DeviceConfig{}), DeviceStatus::Ok);
  ASSERT_EQ(device.activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device.state() == DeviceState::Present; }, kWait));
  mouse.queue_in(0x81, report(1, {215, -115, -35, 0, 0, 115}));
  // Position mode: x +10, y +5 (toward the user is -y), z +1 (pulled up); twist -5° about z.
  ASSERT_TRUE(wait_for_pose(device, {10.0, 5.0, 101.0}));
  DeviceSample sample;
  device.read(0, sample);
  expect_same_rotation(sample.pose.orientation, axis_angle({0, 0, 1}, -5 * kDeg));
  device.deactivate();
}

TEST_F(SpaceMouseTest, ShortMalformedAndUnknownReportsAreCountedAndIgnored) {
  EmulatedUsbDevice mouse(*testbed_, spacemouse_spec(0x046d, 0xc626));
  mouse.plug();
  SpaceMouseDevice device(options(Mode::Position));
  ASSERT_EQ(device.configure(DeviceConfig{}), DeviceStatus::Ok);
  ASSERT_EQ(device.activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device.state() == DeviceState::Present; }, kWait));
  const std::vector<std::vector<std::uint8_t>> packets{
      report(1, {115, 0, 0}),           // good: x +5 mm
      {1, 0x10, 0x00},                  // short
      report(1, {300, 300, 300, 300}),  // malformed length
      report(1, {3000, 0, 0}),          // implausible value: malformed
      {0x17, 0x50},                     // unknown (battery)
      {2, 0, 0},                        // short
      report(2, {0, 0, 0}),             // good
      {3},                              // short
  };
  for (const auto& p : packets) mouse.queue_in(0x81, p);
  ASSERT_TRUE(wait_until(
      [&] {
        const auto c = device.counters();
        return c.reports + c.short_reports + c.malformed + c.unknown == packets.size();
      },
      kWait));
  const SpaceMouseDevice::Counters c = device.counters();
  EXPECT_EQ(c.reports, 2u);
  EXPECT_EQ(c.short_reports, 3u);
  EXPECT_EQ(c.malformed, 2u);
  EXPECT_EQ(c.unknown, 1u);
  ASSERT_TRUE(wait_for_pose(device, {5.0, 0.0, 100.0}));  // only the good reports count
  device.deactivate();
}

TEST_F(SpaceMouseTest, LeftButtonGoesHomeRightButtonLocksThePress) {
  EmulatedUsbDevice mouse(*testbed_, spacemouse_spec(0x046d, 0xc626));
  mouse.plug();
  SpaceMouseDevice device(options(Mode::Rate));
  ASSERT_EQ(device.configure(DeviceConfig{}), DeviceStatus::Ok);
  ASSERT_EQ(device.activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device.state() == DeviceState::Present; }, kWait));
  DeviceSample sample;
  std::int64_t now = 0;
  mouse.queue_in(0x81, report(1, {0, 0, 115}));
  ASSERT_TRUE(wait_until([&] { return device.counters().reports == 1; }, kWait));
  device.read(now, sample);
  for (int i = 0; i < 10; ++i) device.read(now += 10'000'000, sample);  // 0.1 s: 1 mm down
  expect_near(sample.pose.position, {0, 0, 99.0});

  mouse.queue_in(0x81, {3, 0x02});  // right button down: lock the press
  mouse.queue_in(0x81, {3, 0x00});  // and up (the loop sees the press even if it missed the mask)
  mouse.queue_in(0x81, report(1, {115, 0, 350}));
  ASSERT_TRUE(wait_until([&] { return device.counters().reports == 4; }, kWait));
  EXPECT_EQ(device.counters().lock_presses, 1u);
  for (int i = 0; i < 10; ++i) device.read(now += 10'000'000, sample);
  expect_near(sample.pose.position, {1.0, 0, 99.0});  // slides, depth held

  mouse.queue_in(0x81, {3, 0x01});  // left button: home, lock off
  mouse.queue_in(0x81, report(1, {0, 0, 0}));
  ASSERT_TRUE(wait_until([&] { return device.counters().reports == 6; }, kWait));
  EXPECT_EQ(device.counters().home_presses, 1u);
  EXPECT_EQ(device.counters().buttons, 1u);
  device.read(now += 10'000'000, sample);
  expect_near(sample.pose.position, {0, 0, 100.0});
  device.deactivate();
}

TEST_F(SpaceMouseTest, ADeviceWithoutTheHidInterfaceIsRefused) {
  EmulatedUsbDevice impostor(*testbed_, spacemouse_spec(0x046d, 0xc626, 0xff));
  impostor.plug();
  SpaceMouseDevice device(options());
  ASSERT_EQ(device.configure(DeviceConfig{}), DeviceStatus::Ok);
  ASSERT_EQ(device.activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device.state() == DeviceState::Fault; }, kWait));
  EXPECT_NE(device.status_message().find("not a HID interface"), std::string::npos)
      << device.status_message();
  DeviceSample sample;
  EXPECT_EQ(device.read(0, sample), DeviceStatus::Absent);  // zero force
  device.deactivate();
}

// palpd's loop and server in process with the emulated SpaceMouse: it appears after start,
// presses into the ball (forces computed and streamed, not rendered), vanishes mid-stream (the
// loop keeps ticking with zero force, clients see DEVICE_ABSENT) and comes back.
TEST_F(SpaceMouseTest, HotplugUnderARunningLoopAndServer) {
  EmulatedUsbDevice mouse(*testbed_, spacemouse_spec(0x256f, 0xc62e));
  auto model = testing::ball_model();
  std::unique_ptr<Device> device = make_device("spacemouse:rate");
  DeviceConfig device_config;
  device_config.fields = model->fields_ptr();
  device_config.tool = model->tool();
  ASSERT_EQ(device->configure(device_config), DeviceStatus::Ok) << device->last_error();
  ASSERT_EQ(device->activate(), DeviceStatus::Ok);  // nothing plugged in yet
  auto& spacemouse = dynamic_cast<SpaceMouseDevice&>(*device);
  testing::ServedBall served(*device, loop_config(), "spacemouse");
  testing::TestClient& client = served.client();
  v1::ServerMessage m;
  ASSERT_TRUE(client.wait_for_case(v1::ServerMessage::kScene, m, kWait));
  EXPECT_FALSE(m.scene().device_renders_force());  // palpview shows the force on screen
  auto frame_in = [&](v1::DeviceState state) {
    return client.wait_for(
        [state](const v1::ServerMessage& msg) {
          return msg.has_frame() && msg.frame().device_state() == state;
        },
        m, kWait);
  };
  ASSERT_TRUE(frame_in(v1::DEVICE_ABSENT));
  ASSERT_TRUE(wait_until([&] { return served.loop().stats().ticks > 50; }, kWait));

  // Plugged in after start; the cap pressed fully down: 33.5 mm/s toward the ball, 12 mm away.
  mouse.start_in_stream(0x81, 125.0, [](std::uint64_t, std::int64_t) {
    return report(1, {0, 0, 350, 0, 0, 0});
  });
  mouse.plug();
  ASSERT_TRUE(frame_in(v1::DEVICE_PRESENT));
  ASSERT_TRUE(client.wait_for(
      [](const v1::ServerMessage& msg) { return msg.has_frame() && msg.frame().force().z() > 0.1; },
      m, kWait))
      << "the tool never reached the ball";
  EXPECT_GT(spacemouse.counters().writes, 0u);

  mouse.unplug();  // mid-stream
  ASSERT_TRUE(
      wait_until([&] { return served.loop().device_state() == DeviceState::Absent; }, kWait));
  const std::uint64_t ticks_at_unplug = served.loop().stats().ticks;
  ASSERT_TRUE(
      wait_until([&] { return served.loop().stats().ticks > ticks_at_unplug + 50; }, kWait));
  ASSERT_TRUE(frame_in(v1::DEVICE_ABSENT));
  EXPECT_EQ(m.frame().force().z(), 0.0);
  ASSERT_TRUE(client.wait_for(
      [](const v1::ServerMessage& msg) {
        return msg.has_stats() && msg.stats().device_state() == v1::DEVICE_ABSENT;
      },
      m, kWait));
  EXPECT_NE(m.stats().device_message().find("unplugged"), std::string::npos)
      << m.stats().device_message();
  EXPECT_TRUE(served.loop().running());
  EXPECT_EQ(served.loop().stats().faults, 0u);  // absent is not a fault

  mouse.plug();  // back, at a new address
  ASSERT_TRUE(frame_in(v1::DEVICE_PRESENT));
  ASSERT_TRUE(client.wait_for(
      [](const v1::ServerMessage& msg) { return msg.has_frame() && msg.frame().force().z() > 0.1; },
      m, kWait));
  EXPECT_EQ(spacemouse.counters().opens, 2u);
  EXPECT_EQ(mouse.claims(), 2u);
  EXPECT_EQ(served.loop().stats().absent_events, 2u);  // before the first plug, and the unplug
  EXPECT_TRUE(served.loop().running());
  served.stop();
  device->deactivate();
}

}  // namespace
}  // namespace palp::rt
