// `--device falcon` (server/devices/falcon_device.cpp) against an emulated Novint Falcon on an
// in-process umockdev device (tests/support/falcon_emulator): FTDI bridge, bootloader, echo-checked
// firmware upload, homing, the runtime frame exchange, a simulated delta mechanism, and a
// HapticLoop pressing the torso phantom through it. The emulator has its own wire constants and
// kinematics (transcribed from libnifalcon, support/falcon_emulator.hpp): the LED, homing and
// button bits and the motor forces expected here are libnifalcon's, not palp's. Runs under
// umockdev-wrapper; skipped without.
#include "devices/falcon_device.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>
#include <vector>

#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "devices/falcon_kinematics.hpp"
#include "loop/haptic_loop.hpp"
#include "model/registration.hpp"
#include "net/server.hpp"
#include "safety/engagement.hpp"
#include "safety/safety.hpp"
#include "scene/home_site.hpp"
#include "scene/scene.hpp"
#include "support/falcon_emulator.hpp"
#include "support/net_test_client.hpp"
#include "support/palpd_test_util.hpp"
#include "support/served_ball.hpp"
#include "support/usb_emulator.hpp"
#include "wire/messages.hpp"

namespace palp::rt {
namespace {

namespace nif = usbemu::nif;
using usbemu::EmulatedFalcon;
using usbemu::UsbTestbed;
using usbemu::wait_until;

constexpr double kWait = 30.0;  // generous: a loaded 2-core machine

// A stand-in for Novint's firmware image (palp never ships the real one).
std::vector<std::uint8_t> fake_firmware(std::uint32_t seed = 7, std::size_t size = 3000) {
  std::vector<std::uint8_t> image(size);
  for (auto& b : image) {
    seed = seed * 1664525u + 1013904223u;
    b = static_cast<std::uint8_t>(seed >> 24);
  }
  return image;
}

// Forwards to the Falcon and keeps what the loop read and wrote (the force through the limits).
class Tap final : public Device {
 public:
  explicit Tap(FalconDevice& d) : d_(d) {}
  std::string_view kind() const noexcept override { return d_.kind(); }
  DeviceStatus configure(const DeviceConfig& c) override { return d_.configure(c); }
  DeviceStatus activate() override { return d_.activate(); }
  DeviceStatus read(std::int64_t now, DeviceSample& s) noexcept override {
    last_read_ = d_.read(now, s);
    return last_read_;
  }
  DeviceStatus write(const DeviceCommand& c) noexcept override {
    if (last_read_ == DeviceStatus::Absent && norm(c.force) > 0.0) force_after_absent_.fetch_add(1);
    force_[0].store(c.force.x), force_[1].store(c.force.y), force_[2].store(c.force.z);
    return d_.write(c);
  }
  DeviceStatus deactivate() override { return d_.deactivate(); }
  DeviceState state() const noexcept override { return d_.state(); }
  DeclaredLimits declared_limits() const noexcept override { return d_.declared_limits(); }
  Vec3d force() const { return {force_[0].load(), force_[1].load(), force_[2].load()}; }
  std::uint64_t force_after_absent() const { return force_after_absent_.load(); }

 private:
  FalconDevice& d_;
  DeviceStatus last_read_ = DeviceStatus::NoData;
  std::atomic<double> force_[3] = {};
  std::atomic<std::uint64_t> force_after_absent_{0};
};

class FalconTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!UsbTestbed::in_mock_environment()) GTEST_SKIP() << "needs umockdev-wrapper";
    testbed_ = std::make_unique<UsbTestbed>();
  }
  static std::unique_ptr<FalconDevice> falcon(std::vector<std::uint8_t> image = fake_firmware()) {
    auto device = std::make_unique<FalconDevice>(FalconDevice::Options{});
    device->set_firmware(std::move(image), "test.bin");
    EXPECT_EQ(device->configure(DeviceConfig{}), DeviceStatus::Ok);
    return device;
  }
  // The user homes it: pull the handle all the way out, then push it straight in.
  static void home(EmulatedFalcon& emu, FalconDevice& device) {
    emu.hold({0, 0, 160}, 1.0, 0.02);
    ASSERT_TRUE(wait_until([&] { return emu.snapshot().homed == 7; }, kWait));
    emu.hold(falcon::kWorkspaceCentre, 1.0, 0.02);
    ASSERT_TRUE(wait_until([&] { return device.homed(); }, kWait));
  }
  static LoopConfig loop_config() {
    LoopConfig c;
    c.realtime = false;
    c.watchdog_late_s = 0;     // a loaded CI machine: no deadline faults
    c.device_timeout_s = 1.0;  // nor NoData ones
    return c;
  }
  std::unique_ptr<UsbTestbed> testbed_;
};

TEST(FalconSpec, MakeDeviceParsesIndexAndRefusesBadFirmwareFiles) {
  EXPECT_EQ(make_device("falcon")->kind(), "falcon");
  EXPECT_EQ(make_device("falcon:1")->kind(), "falcon");
  EXPECT_THROW(make_device("falcon:x"), UsageError);
  EXPECT_THROW(make_device("falcon:99"), UsageError);
  const std::string missing = "/nonexistent/novint.bin";
  try {
    FalconDevice::read_firmware(missing);
    FAIL() << "a missing firmware file was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("Novint"), std::string::npos) << e.what();
  }
  const auto dir =
      std::filesystem::temp_directory_path() / ("palp-falcon-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string empty = (dir / "empty.bin").string();
  std::ofstream(empty).close();
  try {
    FalconDevice::read_firmware(empty);
    FAIL() << "an empty firmware file was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("empty"), std::string::npos) << e.what();
  }
  const std::string good = (dir / "fw.bin").string();
  {
    std::ofstream f(good, std::ios::binary);
    const auto image = fake_firmware();
    f.write(reinterpret_cast<const char*>(image.data()), std::streamsize(image.size()));
  }
  EXPECT_EQ(FalconDevice::read_firmware(good), fake_firmware());
  std::filesystem::remove_all(dir);
  // no firmware at all: configure refuses, naming the option
  FalconDevice bare(FalconDevice::Options{});
  EXPECT_EQ(bare.configure(DeviceConfig{}), DeviceStatus::Error);
  EXPECT_NE(bare.last_error().find("--falcon-firmware"), std::string::npos);
}

TEST_F(FalconTest, EnumeratesUploadsVerifiesAndWaitsForHoming) {
  EmulatedFalcon emu(*testbed_, fake_firmware());
  emu.power_on();
  auto device = falcon();
  ASSERT_EQ(device->activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device->link_state() == usb::LinkState::Present; }, kWait))
      << device->status_message();
  auto s = emu.snapshot();
  EXPECT_EQ(s.loads, 1u);
  EXPECT_EQ(s.echoed, fake_firmware().size());  // every byte echoed once
  EXPECT_GE(s.probes, 1u);
  EXPECT_EQ(device->counters().uploads, 1u);
  EXPECT_EQ(device->counters().already_running, 0u);
  // not homed: Absent for the loop, red LED and homing asked, the user told what to do
  DeviceSample sample;
  ASSERT_TRUE(wait_until([&] { return device->counters().frames > 20; }, kWait));
  EXPECT_EQ(device->read(0, sample), DeviceStatus::Absent);
  EXPECT_EQ(device->state(), DeviceState::Absent);
  EXPECT_NE(device->status_message().find("pull the handle all the way out"), std::string::npos)
      << device->status_message();
  EXPECT_NE(device->status_message().find("firmware test.bin loaded (3000 bytes, attempt 1)"),
            std::string::npos)
      << device->status_message();
  s = emu.snapshot();
  EXPECT_EQ(s.control, nif::kRedLed | nif::kHomingBit);
  // a force asked before homing never reaches the motors
  device->write(DeviceCommand{{0, 0, 5.0}, {}});
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  home(emu, *device);
  EXPECT_EQ(emu.snapshot().nonzero_while_unhomed, 0u);
  // once the handle has come to rest at the centre, the pose read matches the mechanism's
  ASSERT_TRUE(wait_until(
      [&] { return norm(emu.snapshot().position - falcon::kWorkspaceCentre) < 0.02; }, kWait));
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  // the pose: the handle's position about the workspace centre, within the encoder resolution
  // (read until a frame of the handle at rest arrives: on a loaded machine the first read after
  // homing may carry one still in flight from the move in)
  Vec3d expected;
  EXPECT_TRUE(wait_until(
      [&] {
        expected = emu.snapshot().position - falcon::kWorkspaceCentre;
        return device->read(0, sample) == DeviceStatus::Ok &&
               norm(sample.pose.position - expected) < 0.5;
      },
      kWait))
      << sample.pose.position.x << " " << sample.pose.position.y << " " << sample.pose.position.z;
  EXPECT_EQ(device->state(), DeviceState::Present);
  ASSERT_TRUE(wait_until([&] { return emu.snapshot().control == nif::kGreenLed; }, kWait));
  EXPECT_NE(device->status_message().find("homed"), std::string::npos);
  ASSERT_EQ(device->deactivate(), DeviceStatus::Ok);
}

TEST_F(FalconTest, EchoMismatchIsRetriedThenRefusedWithTheByte) {
  {
    EmulatedFalcon emu(*testbed_, fake_firmware());
    emu.corrupt_echo_attempts(1);  // the first load's echo is wrong, the second is right
    emu.power_on();
    auto device = falcon();
    ASSERT_EQ(device->activate(), DeviceStatus::Ok);
    ASSERT_TRUE(wait_until([&] { return device->link_state() == usb::LinkState::Present; }, kWait))
        << device->status_message();
    EXPECT_EQ(device->counters().upload_failures, 1u);
    EXPECT_EQ(device->counters().uploads, 1u);
    EXPECT_EQ(emu.snapshot().loads, 1u);
    device->deactivate();
  }
  EmulatedFalcon emu(*testbed_, fake_firmware());
  emu.corrupt_echo_attempts(100);  // always wrong: refused after the bounded retries
  emu.power_on();
  auto device = falcon();
  ASSERT_EQ(device->activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device->state() == DeviceState::Fault; }, kWait));
  const std::string message = device->status_message();
  EXPECT_NE(message.find("firmware load failed after 3 attempts"), std::string::npos) << message;
  EXPECT_NE(message.find("echo mismatch at byte 99"), std::string::npos) << message;
  EXPECT_EQ(device->counters().upload_failures, 3u);
  DeviceSample sample;
  EXPECT_EQ(device->read(0, sample), DeviceStatus::Absent);
  device->deactivate();
}

TEST_F(FalconTest, AProbeAnsweredLateDoesNotSpoilTheHandshake) {
  // The first probe's answer comes after the host stopped waiting for it (when it probes again),
  // the second probe's answer after the host read the first: it must not be read as the 'A'
  // echo (the fresh clone's loaded ctest run once failed all three loads so: "'A' not echoed
  // (got 0x0a)", the first byte of a probe's answer).
  EmulatedFalcon emu(*testbed_, fake_firmware());
  emu.delay_first_probe_reply();
  emu.power_on();
  auto device = falcon();
  ASSERT_EQ(device->activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device->link_state() == usb::LinkState::Present; }, kWait))
      << device->status_message();
  EXPECT_EQ(device->counters().upload_failures, 0u) << device->status_message();
  EXPECT_EQ(emu.snapshot().loads, 1u);
  device->deactivate();
}

TEST_F(FalconTest, WrongFirmwareIsRefusedWithTheRightMessage) {
  EmulatedFalcon emu(*testbed_, fake_firmware(7));
  emu.power_on();
  auto device = falcon(fake_firmware(8));  // echoed fine, but not what the DSP runs
  ASSERT_EQ(device->activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device->state() == DeviceState::Fault; }, kWait));
  const std::string message = device->status_message();
  EXPECT_NE(message.find("does not answer runtime frames"), std::string::npos) << message;
  EXPECT_NE(message.find("test.bin"), std::string::npos) << message;
  EXPECT_EQ(emu.snapshot().loads, 0u);
  device->deactivate();
}

TEST_F(FalconTest, RunningFirmwareIsDetectedAndNotReloaded) {
  EmulatedFalcon emu(*testbed_, fake_firmware());
  emu.power_on();
  emu.set_running();
  auto device = falcon();
  ASSERT_EQ(device->activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device->link_state() == usb::LinkState::Present; }, kWait));
  EXPECT_EQ(device->counters().already_running, 1u);
  EXPECT_NE(device->status_message().find("firmware already running"), std::string::npos);
  EXPECT_EQ(device->counters().uploads, 0u);
  EXPECT_EQ(emu.snapshot().echoed, 0u);
  EXPECT_EQ(emu.snapshot().dtr_resets, 0u);  // not even reset
  device->deactivate();
}

// Streams under a running loop; corrupt, short and stray bytes are counted and survived; the
// exchange rate (strictly request / reply over the FTDI bridge) is measured against the loop's.
TEST_F(FalconTest, StreamsAndSurvivesCorruptAndShortFrames) {
  EmulatedFalcon emu(*testbed_, fake_firmware());
  emu.power_on();
  auto device = falcon();
  ASSERT_EQ(device->activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device->link_state() == usb::LinkState::Present; }, kWait));
  home(emu, *device);
  device->set_report_at_stop(true);  // the line palpd prints at exit
  HapticLoop loop(testing::ball_model(), *device, loop_config());
  loop.start();
  const auto c0 = device->counters();
  const std::uint64_t t0 = loop.stats().ticks;
  const auto start = std::chrono::steady_clock::now();
  // Measures, asserts no rate: at least a second, and on until 50 exchanges have gone through
  // (a loaded machine, tests four at a time on two cores, made 39 in the first second).
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  wait_until([&] { return device->counters().frames - c0.frames > 50u; }, kWait);
  const auto c1 = device->counters();
  const std::uint64_t t1 = loop.stats().ticks;
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf(
      "falcon exchange: %.0f exchanges/s (%.0f host frames/s) at a loop of %.0f ticks/s; "
      "%llu lost replies\n",
      double(c1.frames - c0.frames) / s, double(c1.host_frames - c0.host_frames) / s,
      double(t1 - t0) / s, static_cast<unsigned long long>(c1.lost_replies));
  EXPECT_GT(c1.frames - c0.frames, 50u);
  EXPECT_EQ(c1.corrupt, 0u);
  EXPECT_EQ(c1.short_frames, 0u);

  const auto diag = [&] {
    const auto c = device->counters();
    const auto e = emu.snapshot();
    return "device: frames " + std::to_string(c.frames) + " corrupt " + std::to_string(c.corrupt) +
           " short " + std::to_string(c.short_frames) + " host " + std::to_string(c.host_frames) +
           " lost " + std::to_string(c.lost_replies) + " zero " + std::to_string(c.zero_frames) +
           "; emulator: frames in " + std::to_string(e.frames_in) + " replies " +
           std::to_string(e.replies) + "; link " + usb::to_string(device->link_state()) + " " +
           device->status_message() + "; loop ticks " + std::to_string(loop.stats().ticks);
  };
  emu.corrupt_replies(5);
  ASSERT_TRUE(wait_until([&] { return device->counters().corrupt >= 5; }, kWait)) << diag();
  emu.cut_replies(3);
  ASSERT_TRUE(wait_until([&] { return device->counters().short_frames >= 3; }, kWait)) << diag();
  emu.inject({0x00, 0x13, 0x37});
  ASSERT_TRUE(wait_until([&] { return device->counters().frames > c1.frames + 100; }, kWait))
      << diag();
  const auto c2 = device->counters();
  EXPECT_EQ(c2.corrupt, 5u);
  EXPECT_EQ(c2.short_frames, 3u);
  EXPECT_EQ(loop.stats().faults, 0u);
  EXPECT_EQ(loop.stats().absent_events, 0u);
  EXPECT_EQ(device->state(), DeviceState::Present);
  loop.stop();
  // the loop stopped: zero-effort frames keep the exchange going
  ASSERT_TRUE(
      wait_until([&] { return device->counters().zero_frames > c2.zero_frames + 5; }, kWait));
  const auto e = emu.snapshot().efforts;
  EXPECT_EQ(e[0] | e[1] | e[2], 0);
  device->deactivate();
}

// Clients (palp probe, palpview) are told about homing through Stats: absent with what to do,
// then present and homed.
TEST_F(FalconTest, HomingIsReportedToClients) {
  EmulatedFalcon emu(*testbed_, fake_firmware());
  emu.power_on();
  auto device = falcon();
  ASSERT_EQ(device->activate(), DeviceStatus::Ok);
  testing::ServedBall served(*device, loop_config(), "falcon");
  testing::TestClient& client = served.client();
  v1::ServerMessage m;
  auto stats_saying = [&](v1::DeviceState state, const std::string& text) {
    return client.wait_for(
        [&](const v1::ServerMessage& msg) {
          return msg.has_stats() && msg.stats().device_state() == state &&
                 msg.stats().device_message().find(text) != std::string::npos;
        },
        m, kWait);
  };
  ASSERT_TRUE(stats_saying(v1::DEVICE_ABSENT, "pull the handle all the way out"))
      << m.stats().device_message();
  home(emu, *device);
  ASSERT_TRUE(stats_saying(v1::DEVICE_PRESENT, "homed (green LED)")) << m.stats().device_message();
  EXPECT_GT(m.stats().device_exchanges(), 0u);
  // corrupt and short frames are counted in Stats
  emu.corrupt_replies(2);
  emu.cut_replies(1);
  ASSERT_TRUE(client.wait_for(
      [&](const v1::ServerMessage& msg) {
        return msg.has_stats() && msg.stats().device_corrupt_frames() == 2 &&
               msg.stats().device_short_frames() == 1;
      },
      m, kWait));
  served.stop();
  device->deactivate();
}

// The centre grip button is a clutch: held, no force (Absent) and the handle moves freely;
// released, the tool goes on from where it was, not from where the handle now is. The forward
// button re-centres: released, the tool is at the home point wherever the handle is.
TEST_F(FalconTest, CentreButtonIsAClutch) {
  EmulatedFalcon emu(*testbed_, fake_firmware());
  emu.power_on();
  auto device = falcon();
  ASSERT_EQ(device->activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device->link_state() == usb::LinkState::Present; }, kWait));
  home(emu, *device);
  DeviceSample sample;
  const auto settle = [&](const Vec3d& target) {
    emu.hold(target, 1.0, 0.02);
    return wait_until([&] { return norm(emu.snapshot().position - target) < 0.2; }, kWait);
  };
  ASSERT_TRUE(settle(falcon::kWorkspaceCentre));
  // a read from a frame of the handle at rest (the first one after homing may still be in flight
  // from the move in, on a loaded machine)
  ASSERT_TRUE(wait_until(
      [&] {
        return device->read(0, sample) == DeviceStatus::Ok &&
               norm(device->falcon_position() - emu.snapshot().position) < 0.2;
      },
      kWait));
  const Vec3d before = sample.pose.position;
  // plus and minus (libnifalcon's 0x1 and 0x8) are neither clutch nor re-centre
  emu.set_buttons(nif::kPlusButton | nif::kMinusButton);
  ASSERT_TRUE(wait_until([&] { return device->counters().buttons == 0x9; }, kWait));
  EXPECT_EQ(device->read(0, sample), DeviceStatus::Ok);
  emu.set_buttons(0);
  ASSERT_TRUE(wait_until([&] { return device->counters().buttons == 0; }, kWait));
  emu.set_buttons(nif::kCenterButton);
  ASSERT_TRUE(wait_until([&] { return device->read(0, sample) == DeviceStatus::Absent; }, kWait));
  EXPECT_NE(device->status_message().find("clutch held"), std::string::npos);
  // held: blue joins green on the Falcon
  ASSERT_TRUE(wait_until([&] { return emu.snapshot().control == (nif::kGreenLed | nif::kBlueLed); },
                         kWait));
  const Vec3d away = falcon::kWorkspaceCentre + Vec3d{15, 0, -10};
  ASSERT_TRUE(settle(away));  // the handle moves away
  // a frame from there read with the clutch held (the loop reads every tick; this test reads
  // only now and then)
  ASSERT_TRUE(wait_until(
      [&] {
        return device->read(0, sample) == DeviceStatus::Absent &&
               norm(device->falcon_position() - away) < 0.5;
      },
      kWait));
  emu.set_buttons(0);
  ASSERT_TRUE(wait_until([&] { return device->read(0, sample) == DeviceStatus::Ok; }, kWait));
  EXPECT_LT(norm(sample.pose.position - before), 0.5);  // the tool did not jump with the handle
  // and moves on from there with the handle
  ASSERT_TRUE(settle(falcon::kWorkspaceCentre + Vec3d{15, 0, -5}));
  ASSERT_TRUE(wait_until(
      [&] {
        return device->read(0, sample) == DeviceStatus::Ok &&
               std::abs(sample.pose.position.z - (before.z + 5)) < 0.5;
      },
      kWait));
  // the forward button re-centres: released, the handle's place is the workspace centre
  ASSERT_TRUE(settle(falcon::kWorkspaceCentre + Vec3d{10, 5, -8}));
  emu.set_buttons(nif::kForwardButton);
  ASSERT_TRUE(wait_until([&] { return device->read(0, sample) == DeviceStatus::Absent; }, kWait));
  EXPECT_NE(device->status_message().find("re-centre held"), std::string::npos);
  emu.set_buttons(0);
  ASSERT_TRUE(wait_until([&] { return device->read(0, sample) == DeviceStatus::Ok; }, kWait));
  EXPECT_LT(norm(sample.pose.position), 0.5);
  EXPECT_EQ(device->counters().recentres, 1u);
  device->deactivate();
}

// A force the motors cannot render whole near the workspace's edge: no motor effort beyond
// libnifalcon's documented cap (4095) reaches the Falcon, the force the emulated motors put on the
// handle (the emulator's own kinematics) keeps the commanded direction, and the device counts the
// command as limited (Stats.device_force_limited).
TEST_F(FalconTest, ForceBeyondTheEffortCapIsScaledWithItsDirectionKept) {
  EmulatedFalcon emu(*testbed_, fake_firmware());
  emu.power_on();
  auto device = falcon();
  ASSERT_EQ(device->activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device->link_state() == usb::LinkState::Present; }, kWait));
  home(emu, *device);
  // a firm hand holds the handle low and pulled out
  const Vec3d edge = falcon::kWorkspaceCentre + Vec3d{0, -35, 30};
  emu.hold(edge, 5.0, 0.05);
  ASSERT_TRUE(wait_until([&] { return norm(emu.snapshot().position - edge) < 0.5; }, kWait));
  const Vec3d command{0, -8, 0};  // 8 N straight down: over the cap there (docs/devices.md)
  const std::uint64_t limited0 = device->link_counters().force_limited;
  EmulatedFalcon::Snapshot s;
  DeviceSample sample;
  // commands until the Falcon runs efforts palp computed where the handle is (palp's position
  // from a fresh frame, not one still in flight from the move to the edge)
  ASSERT_TRUE(wait_until(
      [&] {
        device->read(0, sample);
        device->write(DeviceCommand{command, {}});
        s = emu.snapshot();
        const int largest = std::max({std::abs(int(s.efforts[0])), std::abs(int(s.efforts[1])),
                                      std::abs(int(s.efforts[2]))});
        return largest == 4095 && norm(device->falcon_position() - s.position) < 0.2;
      },
      kWait))
      << device->status_message();
  EXPECT_EQ(s.over_cap, 0u);
  EXPECT_GT(device->link_counters().force_limited, limited0);
  EXPECT_EQ(device->counters().clamped, device->link_counters().force_limited);
  // the force these efforts put on the handle where it is, by the emulator's own kinematics
  falconref::V3 f{};
  ASSERT_TRUE(falconref::force_from_efforts(
      {s.position.x * 1e-3, s.position.y * 1e-3, s.position.z * 1e-3},
      {double(s.efforts[0]), double(s.efforts[1]), double(s.efforts[2])}, f));
  const Vec3d at_handle{f[0], f[1], f[2]};
  EXPECT_GT(norm(at_handle), 1.0);
  EXPECT_LT(norm(at_handle), 8.0);
  EXPECT_GT(dot(at_handle, command) / (norm(at_handle) * norm(command)), 0.999)
      << at_handle.x << " " << at_handle.y << " " << at_handle.z;
  EXPECT_EQ(emu.snapshot().over_cap, 0u);
  device->deactivate();
}

// The registration palpd uses for a Falcon on the torso: IAR axes, home 20 mm above the anterior
// skin (app/device_placement.cpp).
struct Placed {
  Scene scene;
  Registration registration;
};
Placed torso_placement() {
  SceneOptions options;
  options.cache_dir = (std::filesystem::temp_directory_path() / "palp-falcon-test-scenes").string();
  Placed p{load_scene("phantom:torso", options), {}};
  const HomeSite site = find_home_site(*p.scene.fields, "auto", 20.0);
  p.registration.rotation = rotation_from_axes(patient_frame(p.scene.grid), "IAR");
  p.registration.home = site.home;
  return p;
}

// palpd's loop pressing the torso phantom through the emulated mechanism: the force the motors
// put on the handle is the model's force through the limits; then an unplug mid-press zeroes the
// force within one tick, and a replug reloads the firmware, asks for homing and ramps in.
// `force` (N, Falcon frame) as the motors can render it at `position_mm`: scaled by one factor
// where an effort would pass the documented cap, by libnifalcon's kinematics (falconref).
Vec3d capped_by_reference(const Vec3d& force, const Vec3d& position_mm) {
  falconref::V3 out{};
  if (!falconref::efforts({position_mm.x * 1e-3, position_mm.y * 1e-3, position_mm.z * 1e-3},
                          {force.x, force.y, force.z}, out, 1e30))
    return force;
  const double largest = std::max({std::fabs(out[0]), std::fabs(out[1]), std::fabs(out[2])});
  const double cap = falconref::kDocumentedEffortCap;
  return largest > cap ? force * (cap / largest) : force;
}

TEST_F(FalconTest, ClosedLoopPressesTheTorsoThenSurvivesUnplugAndReplug) {
  const Placed placed = torso_placement();
  EmulatedFalcon emu(*testbed_, fake_firmware());
  emu.power_on();
  auto device = falcon();
  Tap tap(*device);
  ASSERT_EQ(device->activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device->link_state() == usb::LinkState::Present; }, kWait));
  home(emu, *device);

  LoopConfig lc = loop_config();
  lc.profile = &device_profile("falcon");
  EngageParams engage;
  engage.ramp_s = 0.3;
  lc.engage = engage;
  lc.passivity = true;
  lc.registration = placed.registration;
  auto model = std::make_shared<const Model>(placed.scene.fields, parse_tool("finger:7"));
  HapticLoop loop(model, tap, lc);
  loop.start();
  // the hand pushes the handle toward the patient (device -y = posterior), into the skin
  emu.hold(falcon::kWorkspaceCentre + Vec3d{0, -40, 0}, 0.4, 0.02);
  const auto diag = [&] {
    const auto st = loop.stats();
    const auto c = device->counters();
    const auto e = emu.snapshot();
    char text[512];
    std::snprintf(text, sizeof text,
                  "loop: ticks %llu faults %llu last_fault 0x%x absent %llu gain %.2f; device: "
                  "frames %llu fk_failures %llu homed %u; handle (%.1f, %.1f, %.1f) motor force "
                  "(%.2f, %.2f, %.2f); written (%.2f, %.2f, %.2f)",
                  (unsigned long long)st.ticks, (unsigned long long)st.faults, st.last_fault,
                  (unsigned long long)st.absent_events, st.engage_gain,
                  (unsigned long long)c.frames, (unsigned long long)c.fk_failures, c.homed,
                  e.position.x, e.position.y, e.position.z, e.motor_force.x, e.motor_force.y,
                  e.motor_force.z, tap.force().x, tap.force().y, tap.force().z);
    return std::string(text) + "; " + device->status_message();
  };
  ASSERT_TRUE(wait_until([&] { return norm(tap.force()) > 1.0; }, kWait)) << diag();
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // settle against the hand
  // Sampled 100 times, 10 ms apart: the loop's force through the limits (device frame = the
  // Falcon's axes) and the force the emulated motors put on the handle. The two are read at
  // different instants: at rest they agree to the efforts' rounding, but the press may ring a
  // little (the hand's spring against the skin through a 1-2 ms exchange), and a loop held up for
  // 10 ms by a loaded machine makes the device send zero efforts (by design). So the forces are
  // compared as means over the second (a wrong sign, axis or Jacobian is off by 100 % or more),
  // and the single samples are only printed.
  std::vector<double> errors;
  double pressed = 0.0;
  Vec3d sum_commanded{}, sum_handle{};
  for (int i = 0; i < 100; ++i) {
    const auto snap = emu.snapshot();
    // What the motors can render of the loop's force where the handle is: all of it, or, past
    // the documented effort cap, all three efforts scaled by one factor (the reference's own
    // kinematics, not palp's): the press may reach 8 N where the cap leaves less.
    const Vec3d commanded = capped_by_reference(tap.force(), snap.position);
    const Vec3d at_handle = snap.motor_force;
    if (norm(commanded) > 0.5) errors.push_back(norm(at_handle - commanded) / norm(commanded));
    pressed = std::max(pressed, norm(commanded));
    sum_commanded += commanded;
    sum_handle += at_handle;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_GE(errors.size(), 80u);
  std::sort(errors.begin(), errors.end());
  const double mean_error = norm(sum_handle - sum_commanded) / norm(sum_commanded);
  std::printf(
      "torso press: up to %.2f N commanded through the falcon limits; at the handle the mean "
      "force is %.2f %% off; single samples: median %.2f %%, worst %.2f %% (%zu samples)\n",
      pressed, 100 * mean_error, 100 * errors[errors.size() / 2], 100 * errors.back(),
      errors.size());
  EXPECT_GT(pressed, 1.0);
  EXPECT_LE(pressed, 8.0 + 1e-9);  // the falcon profile's limit
  // The efforts' rounding (< 1 %), a stall's zero sample, and the press ringing through the
  // coupling widened for the Falcon's declared 2 ms delay (force and handle read at different
  // instants: 2-15 % apart in the mean over one second on a 2-core VM); a wrong sign, axis or
  // Jacobian is off by 100 % or more.
  EXPECT_LT(mean_error, 0.25);
  EXPECT_GT(emu.snapshot().motor_force.y, 0.5);  // pushed back up, toward anterior
  EXPECT_EQ(emu.snapshot().over_cap, 0u);        // no motor beyond the documented cap

  // unplug mid-press: the first tick that sees it writes zero
  const std::uint64_t absent0 = loop.stats().absent_events;
  const auto unplugged = std::chrono::steady_clock::now();
  emu.unplug();
  ASSERT_TRUE(wait_until([&] { return loop.stats().absent_events > absent0; }, kWait));
  std::printf(
      "unplug seen by the loop within %.1f ms (polled every 1 ms)\n",
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - unplugged)
          .count());
  EXPECT_EQ(tap.force_after_absent(), 0u);
  EXPECT_EQ(norm(tap.force()), 0.0);
  EXPECT_EQ(loop.stats().engage_gain, 0.0);

  // replug: firmware reloaded, homing asked again, no force until homed, then the ramp
  emu.power_on();
  ASSERT_TRUE(wait_until([&] { return device->counters().uploads == 2; }, kWait))
      << device->status_message();
  EXPECT_EQ(emu.snapshot().loads, 2u);  // loaded again after the power came back
  EXPECT_FALSE(device->homed());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(norm(tap.force()), 0.0);
  home(emu, *device);
  emu.hold(falcon::kWorkspaceCentre + Vec3d{0, -40, 0}, 0.4, 0.02);
  bool ramping = false;
  ASSERT_TRUE(wait_until(
      [&] {
        const double g = loop.stats().engage_gain;
        ramping |= g > 0.0 && g < 1.0;
        return g == 1.0;
      },
      kWait));
  EXPECT_TRUE(ramping);
  EXPECT_EQ(emu.snapshot().nonzero_while_unhomed, 0u);
  // unplug, power-up, load and homing were one absent period for the loop, not one per frame
  EXPECT_EQ(loop.stats().absent_events, absent0 + 1);
  EXPECT_EQ(loop.stats().faults, 0u);
  loop.stop();
  device->deactivate();
}

}  // namespace
}  // namespace palp::rt
