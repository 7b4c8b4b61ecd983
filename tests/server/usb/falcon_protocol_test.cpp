// server/usb/falcon_protocol.cpp: the FTDI status bytes, the nibble-encoded 16-byte frames in both
// directions, and the parser's resync and counters on corrupt, short and stray bytes.
#include "usb/falcon_protocol.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace palp::usb::falcon {
namespace {

std::vector<std::uint8_t> device_bytes(const DeviceFrame& f) {
  std::vector<std::uint8_t> b(kFrameSize);
  encode_device_frame(f, b.data());
  return b;
}

TEST(FalconProtocol, StripsTheTwoFtdiStatusBytes) {
  const std::uint8_t packet[] = {0x31, 0x60, 'x', 'y'};
  const std::uint8_t* data = nullptr;
  std::size_t size = 9;
  ASSERT_TRUE(strip_ftdi_status(packet, 4, data, size));
  EXPECT_EQ(size, 2u);
  EXPECT_EQ(data[0], 'x');
  ASSERT_TRUE(strip_ftdi_status(packet, 2, data, size));
  EXPECT_EQ(size, 0u);
  EXPECT_FALSE(strip_ftdi_status(packet, 1, data, size));
}

TEST(FalconProtocol, HostFrameIsNibbleEncodedLeastSignificantFirst) {
  HostFrame f;
  f.efforts = {0x1234, -1, -32768};
  f.control = kHomingMode | kLedRed;
  std::uint8_t b[kFrameSize];
  encode_host_frame(f, b);
  const std::uint8_t expected[kFrameSize] = {'<',  0x45, 0x44, 0x43, 0x42, 0x50, 0x50, 0x50,
                                             0x50, 0x41, 0x41, 0x41, 0x49, 0x4a, 0x41, '>'};
  for (std::size_t i = 0; i < kFrameSize; ++i) EXPECT_EQ(b[i], expected[i]) << i;
  HostFrame back;
  ASSERT_TRUE(decode_host_frame(b, back));
  EXPECT_EQ(back.efforts, f.efforts);
  EXPECT_EQ(back.control, f.control);
}

// The control and grip bits as libnifalcon publishes them (commit f7c727a), written here as
// literals, not taken from the header under test: include/falcon/core/FalconFirmware.h:68-70
// (GREEN_LED 0x2, BLUE_LED 0x4, RED_LED 0x8), src/firmware/FalconFirmwareNovintSDK.cpp:93 (homing
// 0x01), include/falcon/grip/FalconGripFourButton.h:40-43 (PLUS 0x1, FORWARD 0x2, CENTER 0x4,
// MINUS 0x8).
TEST(FalconProtocol, LedHomingAndButtonBitsAreLibnifalcons) {
  EXPECT_EQ(kHomingMode, 0x01);
  EXPECT_EQ(kLedGreen, 0x02);
  EXPECT_EQ(kLedBlue, 0x04);
  EXPECT_EQ(kLedRed, 0x08);
  EXPECT_EQ(kButtonPlus, 0x01);
  EXPECT_EQ(kButtonForward, 0x02);
  EXPECT_EQ(kButtonCentre, 0x04);
  EXPECT_EQ(kButtonMinus, 0x08);
  // homing with the red LED on the wire: byte 13 = 0x41 + (0x08 | 0x01)
  std::uint8_t b[kFrameSize];
  encode_host_frame({{0, 0, 0}, std::uint8_t(kLedRed | kHomingMode)}, b);
  EXPECT_EQ(b[13], 0x41 + 0x09);
  // a Falcon reporting its centre button (0x4) and all three motors homed (bits 4-6)
  const std::uint8_t centre[kFrameSize] = {'<',  0x41, 0x41, 0x41, 0x41, 0x41,        0x41, 0x41,
                                           0x41, 0x41, 0x41, 0x41, 0x41, 0x41 + 0x74, 0x41, '>'};
  DeviceFrame f;
  ASSERT_TRUE(decode_device_frame(centre, f));
  EXPECT_EQ(f.buttons, kButtonCentre);
  EXPECT_TRUE(f.all_homed());
}

TEST(FalconProtocol, DeviceFrameCarriesEncodersButtonsAndHomedBits) {
  DeviceFrame f;
  f.encoders = {-517, 0, 2047};
  f.buttons = kButtonCentre | kButtonPlus;
  f.homed = 0b101;
  const auto b = device_bytes(f);
  EXPECT_EQ(b[13], 0x41 + 0x05 + (0x05 << 4));
  DeviceFrame back;
  ASSERT_TRUE(decode_device_frame(b.data(), back));
  EXPECT_EQ(back.encoders, f.encoders);
  EXPECT_EQ(back.buttons, f.buttons);
  EXPECT_EQ(back.homed, f.homed);
  EXPECT_FALSE(back.all_homed());
}

TEST(FalconProtocol, ParserResyncsAfterCorruptShortAndStrayBytes) {
  DeviceFrame f;
  f.encoders = {1, 2, 3};
  f.homed = 7;
  const auto good = device_bytes(f);
  std::vector<std::uint8_t> stream = {0x00, 0x41, 0x99};  // stray bytes before any frame
  stream.insert(stream.end(), good.begin(), good.end());
  auto corrupt = good;
  corrupt[6] = 0x20;  // a nibble out of range
  stream.insert(stream.end(), corrupt.begin(), corrupt.end());
  stream.insert(stream.end(), good.begin(), good.begin() + 7);  // a frame cut short ...
  stream.insert(stream.end(), good.begin(), good.end());        // ... then a whole one
  auto unterminated = good;
  unterminated[15] = 0x41;  // no '>' at byte 16
  stream.insert(stream.end(), unterminated.begin(), unterminated.end());
  stream.insert(stream.end(), good.begin(), good.end());
  FrameParser parser;
  int delivered = 0;
  // fed in awkward pieces, as USB packets cut the stream anywhere
  for (std::size_t at = 0; at < stream.size(); at += 5)
    parser.feed(stream.data() + at, std::min<std::size_t>(5, stream.size() - at),
                [&](const DeviceFrame& got) {
                  EXPECT_EQ(got.encoders, f.encoders);
                  ++delivered;
                });
  EXPECT_EQ(delivered, 3);
  EXPECT_EQ(parser.counters().frames, 3u);
  EXPECT_EQ(parser.counters().corrupt, 2u);
  EXPECT_EQ(parser.counters().short_frames, 1u);
  EXPECT_EQ(parser.counters().skipped, 3u);
}

}  // namespace
}  // namespace palp::usb::falcon
