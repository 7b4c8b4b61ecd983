// The shared libusb layer (server/usb/usb_context.cpp) against a device emulated in process by
// umockdev (tests/usb_emulator): enumeration by VID:PID, claim, the handshake hook, IN and OUT
// packets, hot-plug (a device that appears after start, unplug, replug) and the permission
// message. Runs under umockdev-wrapper; skipped without it.
#include "usb/usb_context.hpp"

#include <gtest/gtest.h>

#include <libusb.h>

#include <atomic>
#include <vector>

#include "base/errors.hpp"
#include "support/usb_emulator.hpp"

namespace palp::usb {
namespace {

using usbemu::ControlReply;
using usbemu::ControlRequest;
using usbemu::DeviceSpec;
using usbemu::EmulatedUsbDevice;
using usbemu::UsbTestbed;
using usbemu::wait_until;

constexpr double kWait = 20.0;  // generous: a loaded 2-core machine

DeviceSpec spec_of(std::uint16_t vendor, std::uint16_t product) {
  DeviceSpec spec;
  spec.vendor_id = vendor;
  spec.product_id = product;
  spec.interfaces[0].endpoints = {{0x81, 0x03, 64, 1}, {0x01, 0x03, 64, 1}};
  return spec;
}

class UsbContextTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!UsbTestbed::in_mock_environment()) GTEST_SKIP() << "needs umockdev-wrapper";
    testbed_ = std::make_unique<UsbTestbed>();
  }
  std::unique_ptr<UsbTestbed> testbed_;
};

TEST(UsbId, ParsesAndPrints) {
  EXPECT_EQ(parse_usb_id("1209:0001"), (UsbId{0x1209, 0x0001}));
  EXPECT_EQ(parse_usb_id("256F:c635"), (UsbId{0x256f, 0xc635}));
  EXPECT_EQ(to_string(UsbId{0x1209, 0x1}), "1209:0001");
  EXPECT_THROW(parse_usb_id("1209"), UsageError);
  EXPECT_THROW(parse_usb_id("12345:0001"), UsageError);
  EXPECT_THROW(parse_usb_id("12g9:0001"), UsageError);
  EXPECT_THROW(parse_usb_id(":0001"), UsageError);
}

TEST(UsbPermission, MessageNamesTheUdevRule) {
  const std::string m = permission_error_message({0x1209, 0x0001}, "/dev/bus/usb/001/004");
  EXPECT_NE(m.find("deploy/udev/70-palp.rules"), std::string::npos) << m;
  EXPECT_NE(m.find("1209:0001"), std::string::npos) << m;
  EXPECT_NE(m.find("/dev/bus/usb/001/004"), std::string::npos) << m;
  EXPECT_NE(m.find("udevadm"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos);
}

TEST_F(UsbContextTest, EnumeratesByVidPidClaimsAndStreams) {
  EmulatedUsbDevice other(*testbed_, spec_of(0x1209, 0x0002));  // another PID: left alone
  EmulatedUsbDevice device(*testbed_, spec_of(0x1209, 0x0001));
  std::atomic<int> out_packets{0};
  device.on_control([](const ControlRequest& r) {
    return r.request == 0x01 ? ControlReply::in({0xaa, 0xbb}) : ControlReply::stalled();
  });
  device.on_out([&](std::uint8_t endpoint, const std::vector<std::uint8_t>& packet) {
    if (endpoint == 0x01 && packet.size() == 3 && packet[0] == 7) ++out_packets;
  });
  other.plug();
  device.plug();

  auto context = std::make_shared<UsbContext>();
  LinkConfig config;
  config.id = {0x1209, 0x0001};
  config.out_endpoint = 0x01;
  std::vector<std::uint8_t> handshake_reply;
  config.on_open = [&](libusb_device_handle* handle) -> std::string {
    std::uint8_t buffer[8] = {};
    const int n = libusb_control_transfer(handle, 0xc1, 0x01, 0, 0, buffer, sizeof buffer, 1000);
    if (n < 0) return "control failed";
    handshake_reply.assign(buffer, buffer + n);
    return {};
  };
  UsbLink* link_ptr = nullptr;
  std::atomic<int> in_packets{0};
  config.on_in = [&](const std::uint8_t* data, std::size_t size) {
    if (size == 4 && data[0] == 0x42) ++in_packets;
    const std::uint8_t reply[3] = {7, 8, 9};
    link_ptr->send(reply, sizeof reply);
  };
  UsbLink link(context, config);
  link_ptr = &link;
  link.start();
  ASSERT_TRUE(wait_until([&] { return link.state() == LinkState::Present; }, kWait))
      << link.message();
  EXPECT_EQ(device.claims(), 1u);
  EXPECT_EQ(other.claims(), 0u);
  EXPECT_EQ(handshake_reply, (std::vector<std::uint8_t>{0xaa, 0xbb}));
  EXPECT_NE(link.message().find("streaming"), std::string::npos);

  for (int i = 0; i < 10; ++i) device.queue_in(0x81, {0x42, 1, 2, 3});
  ASSERT_TRUE(wait_until(
      [&] {
        return in_packets.load() == 10 && out_packets.load() == 10 && link.out_packets() == 10;
      },
      kWait))
      << in_packets.load() << " in, " << out_packets.load() << " out";
  EXPECT_EQ(link.in_packets(), 10u);
  EXPECT_EQ(link.out_packets(), 10u);
  link.stop();
  EXPECT_EQ(link.state(), LinkState::Absent);
}

TEST_F(UsbContextTest, HotplugArrivalUnplugAndReplug) {
  EmulatedUsbDevice device(*testbed_, spec_of(0x1209, 0x0001));
  auto context = std::make_shared<UsbContext>();
  ASSERT_TRUE(context->has_hotplug());
  LinkConfig config;
  config.id = {0x1209, 0x0001};
  std::atomic<int> opens{0}, closes{0};
  config.on_open = [&](libusb_device_handle*) {
    ++opens;
    return std::string();
  };
  config.on_close = [&] { ++closes; };
  UsbLink link(context, config);
  link.start();  // nothing plugged in yet
  EXPECT_EQ(link.state(), LinkState::Absent);

  device.plug();  // arrives after start
  ASSERT_TRUE(wait_until([&] { return link.state() == LinkState::Present; }, kWait))
      << link.message();
  EXPECT_EQ(opens.load(), 1);

  device.unplug();
  ASSERT_TRUE(wait_until([&] { return link.state() == LinkState::Absent; }, kWait));
  EXPECT_EQ(closes.load(), 1);
  EXPECT_NE(link.message().find("unplugged"), std::string::npos) << link.message();
  EXPECT_GE(link.removals(), 1u);

  device.plug();  // back, at a new device address
  ASSERT_TRUE(wait_until([&] { return link.state() == LinkState::Present; }, kWait))
      << link.message();
  EXPECT_EQ(opens.load(), 2);
  EXPECT_EQ(link.opens(), 2u);
  EXPECT_EQ(device.claims(), 2u);
  link.stop();
}

TEST_F(UsbContextTest, RefusedHandshakeIsAFaultUntilTheDeviceComesBack) {
  EmulatedUsbDevice device(*testbed_, spec_of(0x1209, 0x0001));
  device.plug();
  auto context = std::make_shared<UsbContext>();
  LinkConfig config;
  config.id = {0x1209, 0x0001};
  std::atomic<bool> accept{false};
  config.on_open = [&](libusb_device_handle*) {
    return accept.load() ? std::string() : std::string("firmware too old");
  };
  UsbLink link(context, config);
  link.start();
  ASSERT_TRUE(wait_until([&] { return link.state() == LinkState::Fault; }, kWait));
  EXPECT_NE(link.message().find("firmware too old"), std::string::npos) << link.message();
  EXPECT_NE(link.message().find("1209:0001"), std::string::npos) << link.message();

  accept = true;
  device.unplug();
  ASSERT_TRUE(wait_until([&] { return link.state() == LinkState::Absent; }, kWait));
  device.plug();
  ASSERT_TRUE(wait_until([&] { return link.state() == LinkState::Present; }, kWait))
      << link.message();
  link.stop();
}

}  // namespace
}  // namespace palp::usb
