// The open haptic protocol codecs (server/usb/open_haptic_protocol.cpp): the CRC's check value,
// exact byte offsets from docs/usb-protocol.md, round trips, and every rejection.
#include "usb/open_haptic_protocol.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

namespace palp::usb::ohp {
namespace {

TEST(OpenHapticProtocol, CrcCheckValue) {
  const char* check = "123456789";
  EXPECT_EQ(crc16(reinterpret_cast<const std::uint8_t*>(check), 9), 0x29b1);
}

TEST(OpenHapticProtocol, DeviceFrameLayoutAndRoundTrip) {
  DeviceFrame f;
  f.status = kStatusStreaming | kStatusHomed;
  f.seq = 0x01020304;
  f.device_time_us = 77;
  f.echo = 9;
  f.position_um = {1000, -2000, 3000};
  f.quat_q30 = {1 << 30, 0, 0, 0};
  f.buttons = 0x0003;
  f.faults = kFaultWatchdog;
  std::uint8_t b[kDeviceFrameSize];
  encode_device_frame(f, b);
  EXPECT_EQ(b[0], kFramePose);
  EXPECT_EQ(b[1], 1);
  EXPECT_EQ(b[4], 0x04);  // seq, little-endian
  EXPECT_EQ(b[7], 0x01);
  EXPECT_EQ(b[16], 0xe8);  // 1000 µm
  EXPECT_EQ(b[44], 0x03);
  EXPECT_EQ(b[46], 0x01);
  EXPECT_EQ(b[62] | (b[63] << 8), crc16(b, 62));
  DeviceFrame g;
  ASSERT_EQ(decode_device_frame(b, sizeof b, g), DecodeResult::Ok);
  EXPECT_EQ(g.seq, f.seq);
  EXPECT_EQ(g.echo, 9u);
  EXPECT_EQ(g.position_um, f.position_um);
  EXPECT_EQ(g.faults, kFaultWatchdog);
  Pose pose;
  ASSERT_TRUE(frame_pose(g, kKinematicsNone, pose));
  EXPECT_EQ(pose.position, (Vec3d{1.0, -2.0, 3.0}));
  EXPECT_EQ(pose.orientation, (Quat{1, 0, 0, 0}));
}

TEST(OpenHapticProtocol, RejectsShortWrongAndCorruptFrames) {
  DeviceFrame f, g;
  std::uint8_t b[kDeviceFrameSize];
  encode_device_frame(f, b);
  EXPECT_EQ(decode_device_frame(b, 63, g), DecodeResult::Short);
  std::uint8_t c[kDeviceFrameSize];
  std::memcpy(c, b, sizeof b);
  c[0] = 0x07;
  EXPECT_EQ(decode_device_frame(c, sizeof c, g), DecodeResult::BadType);
  std::memcpy(c, b, sizeof b);
  c[1] = 2;
  EXPECT_EQ(decode_device_frame(c, sizeof c, g), DecodeResult::BadVersion);
  std::memcpy(c, b, sizeof b);
  c[20] ^= 1;
  EXPECT_EQ(decode_device_frame(c, sizeof c, g), DecodeResult::BadCrc);
  // A zero quaternion is not a pose.
  f.quat_q30 = {0, 0, 0, 0};
  Pose pose;
  EXPECT_FALSE(frame_pose(f, kKinematicsNone, pose));
}

TEST(OpenHapticProtocol, HostFrameUnitsAndRoundTrip) {
  HostFrame h;
  h.flags = kFlagEnable | kFlagClearFaults;
  h.seq = 5;
  h.echo = 4;
  h.force_uN = to_uN({1.5, -0.25, 0.000001});
  h.torque_mNmm = to_mNmm({2.0, 0.0, -1.0});
  EXPECT_EQ(h.force_uN, (std::array<std::int32_t, 3>{1'500'000, -250'000, 1}));
  EXPECT_EQ(h.torque_mNmm, (std::array<std::int32_t, 3>{2000, 0, -1000}));
  EXPECT_EQ(to_uN({1e9, -1e9, NAN}),
            (std::array<std::int32_t, 3>{2147483647, -2147483647 - 1, 0}));  // saturated
  std::uint8_t b[kHostFrameSize];
  encode_host_frame(h, b);
  EXPECT_EQ(b[0], kFrameHost);
  EXPECT_EQ(b[2], 3);
  HostFrame g;
  ASSERT_EQ(decode_host_frame(b, sizeof b, g), DecodeResult::Ok);
  EXPECT_EQ(g.force_uN, h.force_uN);
  EXPECT_EQ(g.torque_mNmm, h.torque_mNmm);
  EXPECT_EQ(g.echo, 4u);
  b[13] ^= 0x10;
  EXPECT_EQ(decode_host_frame(b, sizeof b, g), DecodeResult::BadCrc);
}

TEST(OpenHapticProtocol, InfoBlock) {
  Info info;
  info.capabilities = kCapJoints | kCapForce;
  info.kinematics = kKinematicsCartesianRpy;
  info.joint_count = 6;
  std::memcpy(info.name.data(), "bench", 5);
  std::uint8_t b[kInfoSize];
  encode_info(info, b);
  EXPECT_EQ(std::memcmp(b, "PALP", 4), 0);
  Info back;
  ASSERT_TRUE(decode_info(b, sizeof b, back));
  EXPECT_EQ(back.capabilities, info.capabilities);
  EXPECT_EQ(back.kinematics, kKinematicsCartesianRpy);
  EXPECT_STREQ(back.name.data(), "bench");
  EXPECT_FALSE(decode_info(b, kInfoSize - 1, back));
  b[0] = 'X';
  EXPECT_FALSE(decode_info(b, sizeof b, back));
}

// Protocol 1.1: 8 more bytes, stiffness (N/m) and damping (mN s/m), little-endian at 48 and 52;
// a 48-byte (1.0) block leaves both 0.
TEST(OpenHapticProtocol, InfoBlockExtension) {
  Info info;
  info.max_stiffness_N_per_m = 3000;
  info.max_damping_mN_s_per_m = 20000;
  std::uint8_t b[kInfoSize + kInfoExtensionSize];
  std::uint8_t base[kInfoSize];
  encode_info(info, base);
  std::uint8_t extension[kInfoExtensionSize];
  encode_info_extension(info, extension);
  std::memcpy(b, base, kInfoSize);
  std::memcpy(b + kInfoSize, extension, kInfoExtensionSize);
  EXPECT_EQ(b[48], 0xB8);  // 3000 = 0x0BB8
  EXPECT_EQ(b[49], 0x0B);
  Info back;
  ASSERT_TRUE(decode_info(b, sizeof b, back));
  EXPECT_EQ(back.max_stiffness_N_per_m, 3000u);
  EXPECT_EQ(back.max_damping_mN_s_per_m, 20000u);
  ASSERT_TRUE(decode_info(b, kInfoSize, back));
  EXPECT_EQ(back.max_stiffness_N_per_m, 0u);
  EXPECT_EQ(back.max_damping_mN_s_per_m, 0u);
}

TEST(OpenHapticProtocol, CartesianRpyKinematics) {
  DeviceFrame f;
  f.type = kFrameJoints;
  f.joints = {1000, 2000, 3000, 0, 0, static_cast<std::int32_t>(std::lround(M_PI / 2 * 1e6))};
  Pose pose;
  ASSERT_TRUE(frame_pose(f, kKinematicsCartesianRpy, pose));
  EXPECT_EQ(pose.position, (Vec3d{1.0, 2.0, 3.0}));
  EXPECT_NEAR(pose.orientation.w, std::sqrt(0.5), 1e-6);  // 90° about z
  EXPECT_NEAR(pose.orientation.z, std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(pose.orientation.x, 0.0, 1e-12);
  EXPECT_FALSE(frame_pose(f, 9, pose));  // an unknown model is refused
}

}  // namespace
}  // namespace palp::usb::ohp
