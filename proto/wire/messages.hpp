// palp.v1 helpers both ends of the wire use: a message's frame, and palp's vectors, poses and
// device states in and out of their protobuf forms. Server-only conversions (snapshots, client checks) live in
// server/net/protocol.hpp; the client's decoding of frames lives in client/stream/.
#pragma once

#include <string>

#include "base/device_state.hpp"
#include "base/vec.hpp"
#include "palp.pb.h"

namespace palp::wire {

inline constexpr std::uint32_t kProtocolVersion = 1;
inline constexpr std::size_t kMaxNameBytes = 256;  // client_name, token, tool, parameter names
// SceneInfo.structures: at most this many, labelled 1..kMaxStructures (one uint8 a voxel).
inline constexpr std::size_t kMaxStructures = 64;

// The frame (varint prefix + body) of a message.
std::string encode_frame(const google::protobuf::MessageLite& message);

void to_proto(const Vec3d& v, v1::Vec3* out);
void to_proto(const Pose& pose, v1::Pose* out);
Vec3d from_proto(const v1::Vec3& v);
Pose from_proto(const v1::Pose& pose);
// The device's state (base/device_state.hpp, the same numbers): Unknown goes out unspecified;
// unspecified and numbers palp.v1 does not define come in Unknown.
v1::DeviceState to_proto(DeviceState state);
DeviceState from_proto(v1::DeviceState state);

}  // namespace palp::wire
