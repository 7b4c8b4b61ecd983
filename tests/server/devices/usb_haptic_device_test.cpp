// `--device usb-haptic` (server/devices/usb_haptic_device.cpp) against emulated firmware that
// implements docs/usb-protocol.md on an in-process umockdev device (tests/usb_emulator): the
// handshake (and a version mismatch), streaming at 1 kHz with sequence echo, malformed and short
// packets, unplug and replug under a running HapticLoop, the device-side watchdog when the host
// stalls, and clients of an in-process Server seeing DEVICE_ABSENT / DEVICE_PRESENT.
// Runs under umockdev-wrapper; skipped without it.
#include "devices/usb_haptic_device.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <set>
#include <thread>

#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "loop/haptic_loop.hpp"
#include "model/registration.hpp"
#include "net/server.hpp"
#include "safety/engagement.hpp"
#include "safety/safety.hpp"
#include "support/net_test_client.hpp"
#include "support/palpd_test_util.hpp"
#include "support/served_ball.hpp"
#include "support/usb_emulator.hpp"
#include "wire/messages.hpp"

namespace palp::rt {
namespace {

namespace ohp = usb::ohp;
using usbemu::ControlReply;
using usbemu::ControlRequest;
using usbemu::EmulatedUsbDevice;
using usbemu::UsbTestbed;
using usbemu::wait_until;

constexpr double kWait = 20.0;  // generous: a loaded 2-core machine

// Firmware of an open haptic device as docs/usb-protocol.md specifies it, on an emulated USB
// device: GET_INFO / SET_WATCHDOG / CLEAR_FAULTS / HOME / SET_STREAM, a 1 kHz frame stream in
// device time, host frames applied with their echo checked, and the watchdog.
class Firmware {
 public:
  explicit Firmware(UsbTestbed& testbed, std::uint8_t version_major = ohp::kVersionMajor,
                    std::uint32_t max_force_uN = 10'000'000)
      : version_major_(version_major), max_force_uN_(max_force_uN), usb_(testbed, spec()) {
    usb_.on_control([this](const ControlRequest& r) { return control(r); });
    usb_.on_out([this](std::uint8_t endpoint, const std::vector<std::uint8_t>& packet) {
      if (endpoint == ohp::kEndpointOut) host_frame(packet);
    });
  }
  ~Firmware() { usb_.stop_in_stream(); }

  static usbemu::DeviceSpec spec() {
    usbemu::DeviceSpec s;
    s.vendor_id = ohp::kDefaultVendor;
    s.product_id = ohp::kDefaultProduct;
    usbemu::InterfaceSpec& itf = s.interfaces[0];
    itf.interface_class = ohp::kInterfaceClass;
    itf.subclass = ohp::kInterfaceSubclass;
    itf.protocol = ohp::kInterfaceProtocol;
    itf.endpoints = {{ohp::kEndpointIn, 0x03, 64, 1}, {ohp::kEndpointOut, 0x03, 64, 1}};
    return s;
  }

  // Powers up: plugs in and streams frames at `rate_hz` (`max_queued`: endpoint buffering).
  void power_on(double rate_hz = 1000.0, std::size_t max_queued = 4) {
    {
      const std::lock_guard lock(mutex_);
      streaming_ = false;
      faults_ = 0;
      force_ = {};
      last_host_us_ = -1;
    }
    usb_.plug();
    usb_.start_in_stream(
        ohp::kEndpointIn, rate_hz,
        [this](std::uint64_t, std::int64_t device_time_ns) { return tick(device_time_ns); },
        max_queued);
  }
  void unplug() { usb_.unplug(); }
  void plug() { usb_.plug(); }

  // Makes every `every`-th frame bad (CRC) and every `short_every`-th a 10-byte packet.
  void corrupt(int every, int short_every) {
    const std::lock_guard lock(mutex_);
    bad_every_ = every;
    short_every_ = short_every;
  }
  // One more frame, good, outside the stream (a trailing bad frame then shows as a seq gap).
  void send_good_frame() {
    corrupt(0, 0);
    if (auto packet = tick(now_us_ * 1000 + 1000)) usb_.queue_in(ohp::kEndpointIn, *packet);
  }
  void set_pose(const Pose& pose) {
    const std::lock_guard lock(mutex_);
    pose_ = pose;
  }

  struct Seen {
    std::uint64_t frames_sent = 0, good_sent = 0, bad_sent = 0, short_sent = 0;
    std::uint64_t host_frames = 0, bad_echo = 0, clear_requests = 0;
    std::uint32_t watchdog_ms = 0, last_seq = 0;
    bool streaming = false, homed = false;
    std::uint16_t faults = 0;
    std::uint64_t watchdog_trips = 0;
    Vec3d force{};
  };
  Seen seen() {
    const std::lock_guard lock(mutex_);
    Seen s = seen_;
    s.watchdog_ms = watchdog_ms_;
    s.last_seq = seq_;
    s.streaming = streaming_;
    s.faults = faults_;
    s.force = ohp::from_uN(force_);
    return s;
  }
  EmulatedUsbDevice& usb() { return usb_; }

 private:
  ControlReply control(const ControlRequest& r) {
    const std::lock_guard lock(mutex_);
    if ((r.request_type & 0x60) != 0x40) return ControlReply::stalled();  // vendor only
    switch (r.request) {
      case ohp::kGetInfo: {
        ohp::Info info;
        info.version_major = version_major_;
        info.capabilities = ohp::kCapPose | ohp::kCapForce | ohp::kCapTorque | ohp::kCapHoming;
        info.max_force_uN = max_force_uN_;
        std::uint8_t bytes[ohp::kInfoSize];
        ohp::encode_info(info, bytes);
        std::vector<std::uint8_t> reply(bytes, bytes + sizeof bytes);
        if (stiffness_N_per_m_ > 0) {  // a protocol 1.1 device: the extension follows
          info.max_stiffness_N_per_m = stiffness_N_per_m_;
          info.max_damping_mN_s_per_m = damping_mN_s_per_m_;
          std::uint8_t extension[ohp::kInfoExtensionSize];
          ohp::encode_info_extension(info, extension);
          reply.insert(reply.end(), extension, extension + sizeof extension);
        }
        return ControlReply::in(reply);
      }
      case ohp::kSetWatchdog:
        if (r.value < 1 || r.value > 1000) return ControlReply::stalled();
        watchdog_ms_ = r.value;
        return ControlReply::ack();
      case ohp::kClearFaults:
        faults_ = 0;
        return ControlReply::ack();
      case ohp::kHome:
        seen_.homed = true;
        return ControlReply::ack();
      case ohp::kSetStream:
        streaming_ = r.value != 0;
        return ControlReply::ack();
      default:
        return ControlReply::stalled();
    }
  }

  std::optional<std::vector<std::uint8_t>> tick(std::int64_t device_time_ns) {
    const std::lock_guard lock(mutex_);
    const std::int64_t now_us = device_time_ns / 1000;
    now_us_ = now_us;
    if (!streaming_) return std::nullopt;
    // The watchdog: force on and no valid host frame for watchdog_ms -> force off, latched.
    if (last_host_us_ >= 0 && (faults_ & ohp::kFaultWatchdog) == 0 &&
        now_us - last_host_us_ > std::int64_t(watchdog_ms_) * 1000) {
      faults_ |= ohp::kFaultWatchdog;
      force_ = {};
      ++seen_.watchdog_trips;
    }
    ohp::DeviceFrame frame;
    frame.seq = ++seq_;
    sent_seqs_.insert(frame.seq);
    frame.device_time_us = static_cast<std::uint32_t>(now_us);
    frame.echo = host_seq_;
    frame.position_um = ohp::to_um(pose_.position);
    frame.quat_q30 = ohp::to_q30(pose_.orientation);
    frame.status = ohp::kStatusStreaming | ohp::kStatusHomed |
                   (faults_ == 0 && last_host_us_ >= 0 ? ohp::kStatusForceActive : 0);
    frame.faults = faults_;
    std::uint8_t bytes[ohp::kDeviceFrameSize];
    ohp::encode_device_frame(frame, bytes);
    ++seen_.frames_sent;
    if (short_every_ > 0 && frame.seq % std::uint32_t(short_every_) == 0) {
      ++seen_.short_sent;
      return std::vector<std::uint8_t>(bytes, bytes + 10);
    }
    if (bad_every_ > 0 && frame.seq % std::uint32_t(bad_every_) == 0) {
      bytes[20] ^= 0x5a;  // payload changed after the CRC: the host must drop it
      ++seen_.bad_sent;
    } else {
      ++seen_.good_sent;
    }
    return std::vector<std::uint8_t>(bytes, bytes + sizeof bytes);
  }

  void host_frame(const std::vector<std::uint8_t>& packet) {
    const std::lock_guard lock(mutex_);
    ohp::HostFrame frame;
    if (ohp::decode_host_frame(packet.data(), packet.size(), frame) != ohp::DecodeResult::Ok)
      return;
    ++seen_.host_frames;
    if (sent_seqs_.count(frame.echo) == 0 || frame.echo > seq_) ++seen_.bad_echo;
    host_seq_ = frame.seq;
    last_host_us_ = now_us_;
    if (frame.flags & ohp::kFlagClearFaults) {
      ++seen_.clear_requests;
      faults_ = 0;
    }
    force_ = (faults_ == 0 && (frame.flags & ohp::kFlagEnable)) ? frame.force_uN
                                                                : std::array<std::int32_t, 3>{};
  }

  std::uint8_t version_major_;
  std::uint32_t max_force_uN_;

 public:
  std::uint32_t stiffness_N_per_m_ = 0, damping_mN_s_per_m_ = 0;  // 0: a 1.0 device

 private:
  EmulatedUsbDevice usb_;
  std::mutex mutex_;
  Pose pose_ = testing::press_pose(2.0);
  std::uint32_t seq_ = 0, host_seq_ = 0, watchdog_ms_ = 50;
  std::set<std::uint32_t> sent_seqs_;
  bool streaming_ = false;
  std::uint16_t faults_ = 0;
  std::array<std::int32_t, 3> force_{};
  std::int64_t now_us_ = 0, last_host_us_ = -1;
  int bad_every_ = 0, short_every_ = 0;
  Seen seen_;
};

class UsbHapticTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!UsbTestbed::in_mock_environment()) GTEST_SKIP() << "needs umockdev-wrapper";
    testbed_ = std::make_unique<UsbTestbed>();
  }
  // The default usb-haptic device, configured, activated and streaming (the firmware powered on).
  static std::unique_ptr<Device> present_device() {
    std::unique_ptr<Device> device = make_device("usb-haptic:1209:0001");
    EXPECT_EQ(device->configure(DeviceConfig{}), DeviceStatus::Ok);
    EXPECT_EQ(device->activate(), DeviceStatus::Ok);
    EXPECT_TRUE(wait_until([&] { return device->state() == DeviceState::Present; }, kWait));
    return device;
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

TEST(UsbHapticSpec, MakeDeviceParsesVidPid) {
  auto device = make_device("usb-haptic");
  EXPECT_EQ(device->kind(), "usb-haptic");
  EXPECT_TRUE(device->renders_force());
  EXPECT_NO_THROW(make_device("usb-haptic:1209:abcd"));
  EXPECT_THROW(make_device("usb-haptic:zz"), UsageError);
}

TEST_F(UsbHapticTest, HandshakeThenStreamsAtRateWithSequenceEcho) {
  Firmware firmware(*testbed_);
  firmware.power_on(1000.0);
  UsbHapticDevice::Options options;
  options.watchdog_ms = 25;
  UsbHapticDevice device(options);
  ASSERT_EQ(device.activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device.state() == DeviceState::Present; }, kWait))
      << device.status_message();
  const Firmware::Seen handshake = firmware.seen();
  EXPECT_EQ(handshake.watchdog_ms, 25u);
  EXPECT_TRUE(handshake.streaming);
  EXPECT_TRUE(handshake.homed);  // the device declares kCapHoming
  EXPECT_EQ(device.info().version_major, 1);
  EXPECT_TRUE(device.info().capabilities & ohp::kCapForce);

  // The loop presses into the ball: a real force goes back.
  HapticLoop loop(testing::ball_model(), device, loop_config());
  loop.start();
  const std::uint64_t frames0 = device.counters().frames;
  const Firmware::Seen before = firmware.seen();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // measures, asserts no timing
  const Firmware::Seen after = firmware.seen();
  const UsbHapticDevice::Counters c = device.counters();
  loop.stop();
  const std::uint64_t sent = after.frames_sent - before.frames_sent;
  const std::uint64_t received = c.frames - frames0;
  const std::uint64_t answered = after.host_frames - before.host_frames;
  std::printf("0.5 s at 1 kHz: device sent %llu frames, host decoded %llu, answered %llu\n",
              static_cast<unsigned long long>(sent), static_cast<unsigned long long>(received),
              static_cast<unsigned long long>(answered));
  EXPECT_GT(received, 0u);
  EXPECT_GT(answered, 0u);
  EXPECT_EQ(after.bad_echo, 0u);  // every host frame echoes a device seq that was sent
  EXPECT_EQ(c.malformed, 0u);
  EXPECT_EQ(c.short_packets, 0u);
  EXPECT_GT(after.force.z, 0.1);  // pressed from above: pushed back up (N)
  EXPECT_GT(c.last_echo, 0u);     // the device reports the host seq it applied
  ASSERT_EQ(device.deactivate(), DeviceStatus::Ok);
}

TEST_F(UsbHapticTest, MalformedAndShortPacketsAreCountedAndIgnored) {
  Firmware firmware(*testbed_);
  firmware.corrupt(7, 11);
  firmware.power_on(1000.0, 100000);  // nothing dropped in the emulated endpoint
  UsbHapticDevice device(UsbHapticDevice::Options{});
  ASSERT_EQ(device.activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device.counters().frames >= 200; }, kWait));
  firmware.usb().stop_in_stream();
  firmware.send_good_frame();
  const Firmware::Seen seen = firmware.seen();
  ASSERT_TRUE(wait_until([&] { return firmware.usb().in_delivered() == seen.frames_sent; }, kWait));
  ASSERT_TRUE(wait_until(
      [&] {
        const auto c = device.counters();
        return c.frames + c.malformed + c.short_packets == seen.frames_sent;
      },
      kWait));
  const UsbHapticDevice::Counters c = device.counters();
  EXPECT_EQ(c.frames, seen.good_sent);
  EXPECT_EQ(c.malformed, seen.bad_sent);
  EXPECT_EQ(c.short_packets, seen.short_sent);
  EXPECT_GT(c.malformed, 0u);
  EXPECT_GT(c.short_packets, 0u);
  // The dropped frames show up as sequence gaps, nothing else.
  EXPECT_EQ(c.seq_gaps, seen.bad_sent + seen.short_sent);
  DeviceSample sample;
  EXPECT_EQ(device.read(0, sample), DeviceStatus::Ok);  // the newest good frame
  EXPECT_NEAR(sample.pose.position.z, testing::press_pose(2.0).position.z, 1e-3);
  device.deactivate();
}

TEST_F(UsbHapticTest, VersionMismatchIsAClearError) {
  Firmware firmware(*testbed_, 2);
  firmware.power_on();
  UsbHapticDevice device(UsbHapticDevice::Options{});
  ASSERT_EQ(device.activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device.state() == DeviceState::Fault; }, kWait));
  const std::string message = device.status_message();
  EXPECT_NE(message.find("protocol version 2.0"), std::string::npos) << message;
  EXPECT_NE(message.find("palpd speaks 1.0"), std::string::npos) << message;
  DeviceSample sample;
  EXPECT_EQ(device.read(0, sample), DeviceStatus::Absent);  // zero force, not streaming
  EXPECT_FALSE(firmware.seen().streaming);
  device.deactivate();
}

TEST_F(UsbHapticTest, UnplugMidStreamZeroesTheForceAndReplugResumes) {
  Firmware firmware(*testbed_);
  firmware.power_on(1000.0);
  UsbHapticDevice device(UsbHapticDevice::Options{});
  ASSERT_EQ(device.activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device.state() == DeviceState::Present; }, kWait));
  HapticLoop loop(testing::ball_model(), device, loop_config());
  loop.start();
  ASSERT_TRUE(wait_until([&] { return firmware.seen().force.z > 0.1; }, kWait));
  while (loop.net_ring().front()) loop.net_ring().pop();  // only ticks from here on are checked
  ASSERT_EQ(loop.stats().absent_events, 0u);

  firmware.unplug();
  ASSERT_TRUE(wait_until([&] { return loop.device_state() == DeviceState::Absent; }, kWait));
  const std::uint64_t ticks_at_unplug = loop.stats().ticks;
  ASSERT_TRUE(wait_until([&] { return loop.stats().ticks > ticks_at_unplug + 50; }, kWait));
  // Every tick from the first absent one on wrote zero; the loop kept ticking; one event.
  std::uint64_t absent_ticks = 0;
  bool seen_absent = false;
  while (const Snapshot* s = loop.net_ring().front()) {
    if (s->tick.fault & kZeroDeviceAbsent) {
      seen_absent = true;
      ++absent_ticks;
      EXPECT_EQ(s->device_state, DeviceState::Absent);
      EXPECT_EQ(s->tick.force, Vec3d{});
    } else if (seen_absent) {
      ADD_FAILURE() << "a tick after the unplug was not zeroed";
    }
    loop.net_ring().pop();
  }
  EXPECT_GT(absent_ticks, 50u);
  LoopStats stats = loop.stats();
  EXPECT_EQ(stats.absent_events, 1u);
  EXPECT_EQ(stats.faults, 0u);  // absent is not a fault per tick
  EXPECT_NE(device.status_message().find("unplugged"), std::string::npos);

  firmware.plug();  // back: handshake again, force again
  ASSERT_TRUE(wait_until([&] { return loop.device_state() == DeviceState::Present; }, kWait))
      << device.status_message();
  EXPECT_EQ(device.counters().opens, 2u);
  const std::uint64_t answered = firmware.seen().host_frames;
  ASSERT_TRUE(wait_until(
      [&] { return firmware.seen().host_frames > answered + 20 && firmware.seen().force.z > 0.1; },
      kWait));
  stats = loop.stats();
  EXPECT_EQ(stats.absent_events, 1u);
  EXPECT_TRUE(loop.running());
  loop.stop();
  device.deactivate();
}

TEST_F(UsbHapticTest, DeviceWatchdogDropsForceWhenTheHostStalls) {
  Firmware firmware(*testbed_);
  firmware.power_on(1000.0);
  UsbHapticDevice::Options options;
  options.watchdog_ms = 20;
  UsbHapticDevice device(options);
  ASSERT_EQ(device.activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device.state() == DeviceState::Present; }, kWait));
  // The host renders a force...
  const DeviceCommand push{{0.0, 0.0, 1.5}, {}};
  DeviceSample sample;
  ASSERT_TRUE(wait_until(
      [&] {
        device.read(0, sample);
        device.write(push);
        return std::abs(firmware.seen().force.z - 1.5) < 1e-6;
      },
      kWait));
  // ...then stalls: no write, so no host frame; the device's watchdog takes the force off and
  // reports it, and the host sees it.
  ASSERT_TRUE(wait_until([&] { return firmware.seen().faults & ohp::kFaultWatchdog; }, kWait));
  EXPECT_EQ(firmware.seen().force, Vec3d{});
  ASSERT_TRUE(wait_until([&] { return device.read(0, sample) == DeviceStatus::Timeout; }, kWait));
  EXPECT_EQ(device.state(), DeviceState::Fault);
  EXPECT_NE(device.status_message().find("watchdog"), std::string::npos) << device.status_message();
  EXPECT_EQ(device.counters().watchdog_trips, 1u);
  // The host is back: it clears the watchdog fault and the force returns.
  ASSERT_TRUE(wait_until(
      [&] {
        device.write(push);
        return device.read(0, sample) == DeviceStatus::Ok &&
               std::abs(firmware.seen().force.z - 1.5) < 1e-6;
      },
      kWait));
  EXPECT_GE(firmware.seen().clear_requests, 1u);
  EXPECT_EQ(device.state(), DeviceState::Present);
  device.deactivate();
}

// palpd's loop and server in process with the emulated device (a palpd child process would not
// see this process's emulator): a client is told DEVICE_ABSENT after the unplug and
// DEVICE_PRESENT after the replug, in frames and in Stats.
TEST_F(UsbHapticTest, ClientsAreToldWhenTheDeviceComesAndGoes) {
  Firmware firmware(*testbed_);
  firmware.power_on(1000.0);
  std::unique_ptr<Device> device = make_device("usb-haptic:1209:0001");
  ASSERT_EQ(device->configure(DeviceConfig{}), DeviceStatus::Ok);
  ASSERT_EQ(device->activate(), DeviceStatus::Ok);
  ASSERT_TRUE(wait_until([&] { return device->state() == DeviceState::Present; }, kWait));
  testing::ServedBall served(*device, loop_config(), "usb-haptic");
  testing::TestClient& client = served.client();
  v1::ServerMessage m;
  ASSERT_TRUE(client.wait_for_case(v1::ServerMessage::kScene, m, kWait));
  EXPECT_TRUE(m.scene().device_renders_force());
  auto frame_in = [&](v1::DeviceState state) {
    return client.wait_for(
        [state](const v1::ServerMessage& msg) {
          return msg.has_frame() && msg.frame().device_state() == state;
        },
        m, kWait);
  };
  auto stats_in = [&](v1::DeviceState state) {
    return client.wait_for(
        [state](const v1::ServerMessage& msg) {
          return msg.has_stats() && msg.stats().device_state() == state;
        },
        m, kWait);
  };
  ASSERT_TRUE(frame_in(v1::DEVICE_PRESENT));
  firmware.unplug();
  ASSERT_TRUE(frame_in(v1::DEVICE_ABSENT));
  EXPECT_EQ(m.frame().force().z(), 0.0);
  ASSERT_TRUE(stats_in(v1::DEVICE_ABSENT));
  EXPECT_NE(m.stats().device_message().find("unplugged"), std::string::npos)
      << m.stats().device_message();
  firmware.plug();
  ASSERT_TRUE(frame_in(v1::DEVICE_PRESENT));
  ASSERT_TRUE(stats_in(v1::DEVICE_PRESENT));
  EXPECT_NE(m.stats().device_message().find("streaming"), std::string::npos)
      << m.stats().device_message();
  EXPECT_TRUE(served.loop().running());
  served.stop();
  device->deactivate();
}

// A usb-haptic device placed on the patient: its pose lands at home + R·p in the frames clients
// see, SceneInfo carries the registration, and the firmware is written the scene force turned
// back into its own frame (Rᵀ·F).
TEST_F(UsbHapticTest, RegisteredDeviceFeelsTheSceneForceInItsOwnFrame) {
  Firmware firmware(*testbed_);
  firmware.power_on(1000.0);
  std::unique_ptr<Device> device = present_device();
  ASSERT_EQ(device->state(), DeviceState::Present);
  LoopConfig lc = loop_config();
  lc.registration.rotation = rotation_from_axes(PatientFrame{}, "IAR");
  lc.registration.home = {31, 31, 31 + 20 + 8 + 10};  // 10 mm above the top of the ball
  net::SceneDescription::Placement placement;
  placement.registration = lc.registration;
  placement.workspace_half_mm = {50, 50, 50};
  placement.home_site = "auto";
  placement.axes = "IAR";
  // IAR: the device's +x points inferior (scene -z), so 12 mm along it puts the device point 12 mm
  // below home: the pad (8 mm under it) 2 mm into the top of the ball.
  Pose pose;
  pose.position = {12.0, 0.0, 0.0};                                // 12 mm toward inferior
  pose.orientation = Quat{0, std::sqrt(0.5), 0, -std::sqrt(0.5)};  // tool upright in scene
  firmware.set_pose(pose);
  testing::ServedBall served(*device, lc, "usb-haptic", placement);
  testing::TestClient& client = served.client();
  v1::ServerMessage m;
  ASSERT_TRUE(client.wait_for_case(v1::ServerMessage::kScene, m, kWait));
  ASSERT_TRUE(m.scene().has_registration());
  EXPECT_EQ(m.scene().registration().axes(), "IAR");
  EXPECT_EQ(m.scene().registration().rotation_size(), 9);
  EXPECT_EQ(m.scene().registration().home().z(), 69.0);
  ASSERT_TRUE(client.wait_for(
      [](const v1::ServerMessage& msg) {
        return msg.has_frame() && msg.frame().n_contact() > 0 && msg.frame().force().z() > 0.5;
      },
      m, kWait));
  // Scene pose: home + R (12, 0, 0) = (31, 31, 69) + 12 · inferior = (31, 31, 57).
  EXPECT_NEAR(m.frame().device_pose().position().x(), 31.0, 1e-3);
  EXPECT_NEAR(m.frame().device_pose().position().z(), 57.0, 1e-3);
  // The ball pushes the finger up (+z, superior): on the device that is -x.
  const Vec3d scene_force = wire::from_proto(m.frame().force());
  const Vec3d expected = force_to_device(lc.registration, scene_force);
  ASSERT_TRUE(
      wait_until([&] { return std::fabs(firmware.seen().force.x - expected.x) < 0.05; }, kWait));
  EXPECT_LT(firmware.seen().force.x, -0.5);
  EXPECT_NEAR(firmware.seen().force.z, expected.z, 0.05);
  served.stop();
  device->deactivate();
}

// A device declaring 3 N never receives more, whatever the model says: with a profile allowing
// 8 N (the loop lowers it to the declared 3 N) and with no limits in the loop at all (the device's
// own guard), pressing 15 mm into the ball where the model asks for tens of newtons.
TEST_F(UsbHapticTest, ADeviceDeclaring3NeverGetsMoreThan3N) {
  for (const bool loop_limits : {true, false}) {
    SCOPED_TRACE(loop_limits ? "falcon profile in the loop" : "no limits in the loop");
    Firmware firmware(*testbed_, ohp::kVersionMajor, 3'000'000);
    firmware.power_on(1000.0);
    std::unique_ptr<Device> device = present_device();
    ASSERT_EQ(device->state(), DeviceState::Present);
    EXPECT_EQ(device->declared_max_force_N(), 3.0);
    EXPECT_EQ(device->declared_limits().max_stiffness_N_per_mm, 0.0);  // a 1.0 device
    LoopConfig lc = loop_config();
    if (loop_limits) {
      lc.profile = &device_profile("falcon");
      lc.engage = EngageParams{0.2, 0.05};
    }
    HapticLoop loop(testing::ball_model(), *device, lc);
    Pose lifted;
    lifted.position = {31, 31, 90};
    firmware.set_pose(lifted);  // out of contact first, so the force engages
    loop.start();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    firmware.set_pose(testing::press_pose(15.0));
    // The falcon profile lets a held force settle at 3 N/s (lowered with the declared force):
    // watch for up to 4 s, and 200 ms more once it is there.
    double largest = 0.0;
    auto until = std::chrono::steady_clock::now() + std::chrono::seconds(4);
    bool there = false;
    while (std::chrono::steady_clock::now() < until) {
      largest = std::max(largest, norm(firmware.seen().force));
      if (!there && largest > 2.95) {
        there = true;
        until = std::chrono::steady_clock::now() + std::chrono::milliseconds(200);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    EXPECT_GT(largest, 2.9);         // it pushes back as hard as it may
    EXPECT_LE(largest, 3.0 + 1e-6);  // and no harder (the wire's micronewtons)
    loop.stop();
    device->deactivate();
    firmware.unplug();
  }
}

// A protocol 1.1 device declares its stable stiffness and damping in the InfoBlock's extension;
// palpd reads them (and a 1.0 device's 48 bytes stay accepted, above).
TEST_F(UsbHapticTest, ProtocolOneOneDeclaresStiffnessAndDamping) {
  Firmware firmware(*testbed_, ohp::kVersionMajor, 3'300'000);
  firmware.stiffness_N_per_m_ = 400;
  firmware.damping_mN_s_per_m_ = 4000;
  firmware.power_on(1000.0);
  std::unique_ptr<Device> device = present_device();
  ASSERT_EQ(device->state(), DeviceState::Present);
  const DeclaredLimits d = device->declared_limits();
  EXPECT_DOUBLE_EQ(d.max_force_N, 3.3);
  EXPECT_DOUBLE_EQ(d.max_stiffness_N_per_mm, 0.4);
  EXPECT_DOUBLE_EQ(d.damping_N_s_per_mm, 0.004);
  // The falcon profile, lowered to this device: the touch class's numbers.
  const DeviceProfile p = with_declared(device_profile("falcon"), d);
  EXPECT_DOUBLE_EQ(p.max_force_N, 3.3);
  EXPECT_DOUBLE_EQ(p.max_stiffness_N_per_mm, 0.4);
  EXPECT_DOUBLE_EQ(p.damping_N_s_per_mm, 0.004);
  device->deactivate();
}

}  // namespace
}  // namespace palp::rt
