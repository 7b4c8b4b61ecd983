// palp.v1 helpers shared by palpd and its clients: see messages.hpp.
#include "wire/messages.hpp"

#include <algorithm>

#include "wire/framing.hpp"

namespace palp::wire {

std::string encode_frame(const google::protobuf::MessageLite& message) {
  const std::size_t size = message.ByteSizeLong();
  std::uint8_t prefix[kMaxVarintBytes];
  const std::size_t n = encode_varint(size, prefix);
  std::string out(n + size, '\0');
  std::copy(prefix, prefix + n, out.begin());
  message.SerializeWithCachedSizesToArray(reinterpret_cast<std::uint8_t*>(out.data() + n));
  return out;
}

void to_proto(const Vec3d& v, v1::Vec3* out) {
  out->set_x(v.x);
  out->set_y(v.y);
  out->set_z(v.z);
}

void to_proto(const Pose& pose, v1::Pose* out) {
  to_proto(pose.position, out->mutable_position());
  v1::Quat* q = out->mutable_orientation();
  q->set_w(pose.orientation.w);
  q->set_x(pose.orientation.x);
  q->set_y(pose.orientation.y);
  q->set_z(pose.orientation.z);
}

Vec3d from_proto(const v1::Vec3& v) {
  return {v.x(), v.y(), v.z()};
}

Pose from_proto(const v1::Pose& pose) {
  Pose p;
  p.position = from_proto(pose.position());
  const v1::Quat& q = pose.orientation();
  p.orientation = pose.has_orientation() ? Quat{q.w(), q.x(), q.y(), q.z()} : Quat{};
  return p;
}

v1::DeviceState to_proto(DeviceState state) {
  switch (state) {
    case DeviceState::Present:
      return v1::DEVICE_PRESENT;
    case DeviceState::Absent:
      return v1::DEVICE_ABSENT;
    case DeviceState::Fault:
      return v1::DEVICE_FAULT;
    case DeviceState::Unknown:
      break;
  }
  return v1::DEVICE_STATE_UNSPECIFIED;
}

DeviceState from_proto(v1::DeviceState state) {
  switch (state) {
    case v1::DEVICE_PRESENT:
      return DeviceState::Present;
    case v1::DEVICE_ABSENT:
      return DeviceState::Absent;
    case v1::DEVICE_FAULT:
      return DeviceState::Fault;
    default:
      return DeviceState::Unknown;
  }
}

}  // namespace palp::wire
