// Byte-level codecs of the open haptic protocol (see open_haptic_protocol.hpp and
// docs/usb-protocol.md): little-endian fields at fixed offsets, CRC last.
#include "usb/open_haptic_protocol.hpp"

#include <cmath>
#include <cstring>
#include <limits>

namespace palp::usb::ohp {
namespace {

void put16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
void put32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
std::uint16_t get16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
std::uint32_t get32(const std::uint8_t* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) |
         (std::uint32_t(p[3]) << 24);
}

std::int32_t saturate(double value) {
  if (!std::isfinite(value)) return 0;
  const double r = std::round(value);
  if (r >= double(std::numeric_limits<std::int32_t>::max()))
    return std::numeric_limits<std::int32_t>::max();
  if (r <= double(std::numeric_limits<std::int32_t>::min()))
    return std::numeric_limits<std::int32_t>::min();
  return static_cast<std::int32_t>(r);
}

constexpr double kQ30 = 1073741824.0;  // 2^30

}  // namespace

std::uint16_t crc16(const std::uint8_t* data, std::size_t size) noexcept {
  std::uint16_t crc = 0xffff;
  for (std::size_t i = 0; i < size; ++i) {
    crc = static_cast<std::uint16_t>(crc ^ (std::uint16_t(data[i]) << 8));
    for (int bit = 0; bit < 8; ++bit)
      crc = static_cast<std::uint16_t>((crc & 0x8000) ? (crc << 1) ^ 0x1021 : crc << 1);
  }
  return crc;
}

const char* to_string(DecodeResult result) noexcept {
  switch (result) {
    case DecodeResult::Ok:
      return "ok";
    case DecodeResult::Short:
      return "short";
    case DecodeResult::BadType:
      return "bad type";
    case DecodeResult::BadVersion:
      return "bad version";
    case DecodeResult::BadCrc:
      break;
  }
  return "bad crc";
}

void encode_info(const Info& info, std::uint8_t (&out)[kInfoSize]) noexcept {
  std::memset(out, 0, kInfoSize);
  std::memcpy(out, "PALP", 4);
  out[4] = info.version_major;
  out[5] = info.version_minor;
  put16(out + 6, info.capabilities);
  put16(out + 8, info.frame_rate_hz);
  put16(out + 10, info.watchdog_ms);
  put32(out + 12, info.max_force_uN);
  put32(out + 16, info.max_torque_mNmm);
  out[20] = info.kinematics;
  out[21] = info.joint_count;
  put16(out + 22, info.firmware_version);
  std::memcpy(out + 24, info.name.data(), info.name.size());
}

bool decode_info(const std::uint8_t* data, std::size_t size, Info& out) noexcept {
  if (size < kInfoSize || std::memcmp(data, "PALP", 4) != 0) return false;
  out.version_major = data[4];
  out.version_minor = data[5];
  out.capabilities = get16(data + 6);
  out.frame_rate_hz = get16(data + 8);
  out.watchdog_ms = get16(data + 10);
  out.max_force_uN = get32(data + 12);
  out.max_torque_mNmm = get32(data + 16);
  out.kinematics = data[20];
  out.joint_count = data[21];
  out.firmware_version = get16(data + 22);
  std::memcpy(out.name.data(), data + 24, out.name.size());
  out.name.back() = '\0';
  out.max_stiffness_N_per_m = 0;
  out.max_damping_mN_s_per_m = 0;
  if (size >= kInfoSize + kInfoExtensionSize) {
    out.max_stiffness_N_per_m = get32(data + 48);
    out.max_damping_mN_s_per_m = get32(data + 52);
  }
  return true;
}

void encode_info_extension(const Info& info, std::uint8_t (&out)[kInfoExtensionSize]) noexcept {
  put32(out, info.max_stiffness_N_per_m);
  put32(out + 4, info.max_damping_mN_s_per_m);
}

void encode_device_frame(const DeviceFrame& f, std::uint8_t (&out)[kDeviceFrameSize]) noexcept {
  std::memset(out, 0, kDeviceFrameSize);
  out[0] = f.type;
  out[1] = f.version_major;
  put16(out + 2, f.status);
  put32(out + 4, f.seq);
  put32(out + 8, f.device_time_us);
  put32(out + 12, f.echo);
  if (f.type == kFrameJoints) {
    for (std::size_t i = 0; i < kMaxJoints; ++i)
      put32(out + 16 + 4 * i, static_cast<std::uint32_t>(f.joints[i]));
  } else {
    for (std::size_t i = 0; i < 3; ++i)
      put32(out + 16 + 4 * i, static_cast<std::uint32_t>(f.position_um[i]));
    for (std::size_t i = 0; i < 4; ++i)
      put32(out + 28 + 4 * i, static_cast<std::uint32_t>(f.quat_q30[i]));
  }
  put16(out + 44, f.buttons);
  put16(out + 46, f.faults);
  put16(out + 62, crc16(out, 62));
}

DecodeResult decode_device_frame(const std::uint8_t* data, std::size_t size,
                                 DeviceFrame& f) noexcept {
  if (size < kDeviceFrameSize) return DecodeResult::Short;
  if (data[0] != kFramePose && data[0] != kFrameJoints) return DecodeResult::BadType;
  if (data[1] != kVersionMajor) return DecodeResult::BadVersion;
  if (get16(data + 62) != crc16(data, 62)) return DecodeResult::BadCrc;
  f.type = data[0];
  f.version_major = data[1];
  f.status = get16(data + 2);
  f.seq = get32(data + 4);
  f.device_time_us = get32(data + 8);
  f.echo = get32(data + 12);
  if (f.type == kFrameJoints) {
    for (std::size_t i = 0; i < kMaxJoints; ++i)
      f.joints[i] = static_cast<std::int32_t>(get32(data + 16 + 4 * i));
  } else {
    for (std::size_t i = 0; i < 3; ++i)
      f.position_um[i] = static_cast<std::int32_t>(get32(data + 16 + 4 * i));
    for (std::size_t i = 0; i < 4; ++i)
      f.quat_q30[i] = static_cast<std::int32_t>(get32(data + 28 + 4 * i));
  }
  f.buttons = get16(data + 44);
  f.faults = get16(data + 46);
  return DecodeResult::Ok;
}

void encode_host_frame(const HostFrame& f, std::uint8_t (&out)[kHostFrameSize]) noexcept {
  std::memset(out, 0, kHostFrameSize);
  out[0] = kFrameHost;
  out[1] = kVersionMajor;
  put16(out + 2, f.flags);
  put32(out + 4, f.seq);
  put32(out + 8, f.echo);
  for (std::size_t i = 0; i < 3; ++i) {
    put32(out + 12 + 4 * i, static_cast<std::uint32_t>(f.force_uN[i]));
    put32(out + 24 + 4 * i, static_cast<std::uint32_t>(f.torque_mNmm[i]));
  }
  put16(out + 38, crc16(out, 38));
}

DecodeResult decode_host_frame(const std::uint8_t* data, std::size_t size, HostFrame& f) noexcept {
  if (size < kHostFrameSize) return DecodeResult::Short;
  if (data[0] != kFrameHost) return DecodeResult::BadType;
  if (data[1] != kVersionMajor) return DecodeResult::BadVersion;
  if (get16(data + 38) != crc16(data, 38)) return DecodeResult::BadCrc;
  f.flags = get16(data + 2);
  f.seq = get32(data + 4);
  f.echo = get32(data + 8);
  for (std::size_t i = 0; i < 3; ++i) {
    f.force_uN[i] = static_cast<std::int32_t>(get32(data + 12 + 4 * i));
    f.torque_mNmm[i] = static_cast<std::int32_t>(get32(data + 24 + 4 * i));
  }
  return DecodeResult::Ok;
}

std::array<std::int32_t, 3> to_um(const Vec3d& mm) noexcept {
  return {saturate(mm.x * 1000.0), saturate(mm.y * 1000.0), saturate(mm.z * 1000.0)};
}

std::array<std::int32_t, 4> to_q30(const Quat& q) noexcept {
  return {saturate(q.w * kQ30), saturate(q.x * kQ30), saturate(q.y * kQ30), saturate(q.z * kQ30)};
}

std::array<std::int32_t, 3> to_uN(const Vec3d& newton) noexcept {
  return {saturate(newton.x * 1e6), saturate(newton.y * 1e6), saturate(newton.z * 1e6)};
}

std::array<std::int32_t, 3> to_mNmm(const Vec3d& newton_mm) noexcept {
  return {saturate(newton_mm.x * 1e3), saturate(newton_mm.y * 1e3), saturate(newton_mm.z * 1e3)};
}

Vec3d from_uN(const std::array<std::int32_t, 3>& micro_newton) noexcept {
  return {micro_newton[0] * 1e-6, micro_newton[1] * 1e-6, micro_newton[2] * 1e-6};
}

bool frame_pose(const DeviceFrame& frame, std::uint8_t kinematics, Pose& out) noexcept {
  if (frame.type == kFramePose) {
    out.position = {frame.position_um[0] * 1e-3, frame.position_um[1] * 1e-3,
                    frame.position_um[2] * 1e-3};
    const Quat q{frame.quat_q30[0] / kQ30, frame.quat_q30[1] / kQ30, frame.quat_q30[2] / kQ30,
                 frame.quat_q30[3] / kQ30};
    const double n = norm(q);
    if (!(n > 0.5 && n < 1.5)) return false;
    out.orientation = Quat{q.w / n, q.x / n, q.y / n, q.z / n};
    return true;
  }
  if (frame.type != kFrameJoints || kinematics != kKinematicsCartesianRpy) return false;
  out.position = {frame.joints[0] * 1e-3, frame.joints[1] * 1e-3, frame.joints[2] * 1e-3};
  // q = Rz(yaw) · Ry(pitch) · Rx(roll)
  const double roll = frame.joints[3] * 1e-6, pitch = frame.joints[4] * 1e-6,
               yaw = frame.joints[5] * 1e-6;
  const double cr = std::cos(roll / 2), sr = std::sin(roll / 2);
  const double cp = std::cos(pitch / 2), sp = std::sin(pitch / 2);
  const double cy = std::cos(yaw / 2), sy = std::sin(yaw / 2);
  out.orientation = Quat{cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                         cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy};
  return true;
}

}  // namespace palp::usb::ohp
