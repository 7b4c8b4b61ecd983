// The open haptic device protocol, version 1.0 (docs/usb-protocol.md is the normative text):
// byte layouts, constants, and encoders/decoders for both directions. Pure: no libusb, no
// allocation, no exceptions in the frame codecs, so the same code serves palpd's device
// (usb_haptic_device.cpp), the emulated firmware in the tests, and firmware authors as a
// reference.
//
//   device ─IN 0x81, 64-byte DeviceFrame every ≤1 ms─► host: seq, device time, pose or joints,
//                                                          buttons, status, faults, host-seq echo
//   host ─OUT 0x01, 40-byte HostFrame per device frame─► device: seq, echo, force, torque, flags
//   control (vendor, recipient interface): GET_INFO (version, capabilities, kinematics),
//   SET_WATCHDOG, CLEAR_FAULTS, HOME, SET_STREAM
// All integers little-endian; every frame ends in a CRC-16/CCITT-FALSE over the bytes before it.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "base/vec.hpp"
#include "model/force_model.hpp"

namespace palp::usb::ohp {

inline constexpr std::uint16_t kDefaultVendor = 0x1209;   // pid.codes
inline constexpr std::uint16_t kDefaultProduct = 0x0001;  // pid.codes test PID
inline constexpr std::uint8_t kVersionMajor = 1;
inline constexpr std::uint8_t kVersionMinor = 0;

// The interface: vendor class, subclass 'P', protocol 1.
inline constexpr std::uint8_t kInterfaceClass = 0xff;
inline constexpr std::uint8_t kInterfaceSubclass = 0x50;
inline constexpr std::uint8_t kInterfaceProtocol = 0x01;
inline constexpr std::uint8_t kEndpointIn = 0x81;
inline constexpr std::uint8_t kEndpointOut = 0x01;

// Vendor control requests (bmRequestType 0xC1 for IN, 0x41 for OUT; wIndex = interface).
enum Request : std::uint8_t {
  kGetInfo = 0x01,      // IN, wLength >= 48: the InfoBlock
  kSetStream = 0x02,    // OUT, wValue 1 = start sending device frames, 0 = stop
  kSetWatchdog = 0x03,  // OUT, wValue = watchdog period in ms (1..1000)
  kHome = 0x04,         // OUT: start homing / calibration (status kStatusHoming until done)
  kClearFaults = 0x05,  // OUT: clear latched faults
};

// InfoBlock capability bits.
enum Capability : std::uint16_t {
  kCapPose = 1u << 0,     // sends pose frames (type 0x01)
  kCapJoints = 1u << 1,   // sends joint frames (type 0x02) with a declared kinematic model
  kCapForce = 1u << 2,    // renders force
  kCapTorque = 1u << 3,   // renders torque
  kCapHoming = 1u << 4,   // needs HOME before its pose is meaningful
  kCapButtons = 1u << 5,  // reports buttons
};

// Declared kinematic models for joint frames.
enum KinematicModel : std::uint8_t {
  kKinematicsNone = 0,          // pose frames only
  kKinematicsCartesianRpy = 1,  // joints 0-2: x, y, z in µm; 3-5: roll, pitch, yaw in µrad
};

// DeviceFrame status bits.
enum Status : std::uint16_t {
  kStatusStreaming = 1u << 0,
  kStatusForceActive = 1u << 1,  // the actuators render the host's force
  kStatusHomed = 1u << 2,
  kStatusHoming = 1u << 3,
};

// DeviceFrame fault bits (latched until CLEAR_FAULTS or a host frame with kFlagClearFaults).
enum Fault : std::uint16_t {
  kFaultWatchdog = 1u << 0,  // no valid host frame within the watchdog period: force dropped
  kFaultOvercurrent = 1u << 1,
  kFaultOvertemp = 1u << 2,
  kFaultEncoder = 1u << 3,
  kFaultEstop = 1u << 4,
  kFaultNotHomed = 1u << 5,
};

// HostFrame flag bits.
enum HostFlag : std::uint16_t {
  kFlagEnable = 1u << 0,       // render this force (0: zero output)
  kFlagClearFaults = 1u << 1,  // clear latched faults
};

inline constexpr std::uint8_t kFramePose = 0x01;
inline constexpr std::uint8_t kFrameJoints = 0x02;
inline constexpr std::uint8_t kFrameHost = 0x81;
inline constexpr std::size_t kDeviceFrameSize = 64;
inline constexpr std::size_t kHostFrameSize = 40;
inline constexpr std::size_t kInfoSize = 48;
// Protocol 1.1 appends 8 bytes (GET_INFO may answer 56): the device's own stable stiffness and
// damping. A 1.0 device answers 48 and declares neither.
inline constexpr std::size_t kInfoExtensionSize = 8;
inline constexpr std::size_t kMaxJoints = 6;

struct Info {
  std::uint8_t version_major = kVersionMajor;
  std::uint8_t version_minor = kVersionMinor;
  std::uint16_t capabilities = kCapPose | kCapForce;
  std::uint16_t frame_rate_hz = 1000;
  std::uint16_t watchdog_ms = 20;
  std::uint32_t max_force_uN = 10'000'000;  // 10 N
  std::uint32_t max_torque_mNmm = 0;
  std::uint8_t kinematics = kKinematicsNone;
  std::uint8_t joint_count = 0;
  std::uint16_t firmware_version = 0;
  std::array<char, 24> name{};  // NUL-padded
  // 1.1 extension (0: not declared).
  std::uint32_t max_stiffness_N_per_m = 0;   // largest stiffness rendered stably
  std::uint32_t max_damping_mN_s_per_m = 0;  // largest damping rendered stably
};

struct DeviceFrame {
  std::uint8_t type = kFramePose;
  std::uint8_t version_major = kVersionMajor;
  std::uint16_t status = 0;
  std::uint32_t seq = 0;
  std::uint32_t device_time_us = 0;
  std::uint32_t echo = 0;                         // the last host seq the device applied
  std::array<std::int32_t, 3> position_um{};      // pose frames
  std::array<std::int32_t, 4> quat_q30{};         // w, x, y, z × 2^30 (pose frames)
  std::array<std::int32_t, kMaxJoints> joints{};  // joint frames
  std::uint16_t buttons = 0;
  std::uint16_t faults = 0;
};

struct HostFrame {
  std::uint16_t flags = 0;
  std::uint32_t seq = 0;
  std::uint32_t echo = 0;  // the device seq this frame answers
  std::array<std::int32_t, 3> force_uN{};
  std::array<std::int32_t, 3> torque_mNmm{};
};

// CRC-16/CCITT-FALSE (poly 0x1021, init 0xffff, no reflection, no final xor).
std::uint16_t crc16(const std::uint8_t* data, std::size_t size) noexcept;

enum class DecodeResult : std::uint8_t { Ok, Short, BadType, BadVersion, BadCrc };
const char* to_string(DecodeResult result) noexcept;

void encode_info(const Info& info, std::uint8_t (&out)[kInfoSize]) noexcept;
// The 1.1 extension (bytes 48..55 of a 56-byte reply).
void encode_info_extension(const Info& info, std::uint8_t (&out)[kInfoExtensionSize]) noexcept;
// False when shorter than kInfoSize or without the "PALP" magic. The 1.1 extension is read when
// `size` covers it.
bool decode_info(const std::uint8_t* data, std::size_t size, Info& out) noexcept;

void encode_device_frame(const DeviceFrame& frame, std::uint8_t (&out)[kDeviceFrameSize]) noexcept;
DecodeResult decode_device_frame(const std::uint8_t* data, std::size_t size,
                                 DeviceFrame& out) noexcept;

void encode_host_frame(const HostFrame& frame, std::uint8_t (&out)[kHostFrameSize]) noexcept;
DecodeResult decode_host_frame(const std::uint8_t* data, std::size_t size, HostFrame& out) noexcept;

// Units: mm and a unit quaternion <-> µm and q30; N <-> µN; N·mm <-> mN·mm (saturating).
std::array<std::int32_t, 3> to_um(const Vec3d& mm) noexcept;
std::array<std::int32_t, 4> to_q30(const Quat& q) noexcept;
std::array<std::int32_t, 3> to_uN(const Vec3d& newton) noexcept;
std::array<std::int32_t, 3> to_mNmm(const Vec3d& newton_mm) noexcept;
Vec3d from_uN(const std::array<std::int32_t, 3>& micro_newton) noexcept;
// The pose a device frame stands for: pose frames directly, joint frames through `kinematics`.
// False for an unknown model or a degenerate quaternion.
bool frame_pose(const DeviceFrame& frame, std::uint8_t kinematics, Pose& out) noexcept;

}  // namespace palp::usb::ohp
