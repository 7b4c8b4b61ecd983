// palp.v1 messages <-> palp types, message framing, and the checks every client message passes.
// The only header besides server.cpp and the probe that includes the generated palp.pb.h.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "force_model.hpp"
#include "palp.pb.h"
#include "snapshot.hpp"
#include "vec.hpp"

namespace palp::net {

inline constexpr std::uint32_t kProtocolVersion = 1;
inline constexpr std::size_t kMaxNameBytes = 256;  // client_name, token, tool, parameter names

// The frame (varint prefix + body) of a message.
std::string encode_frame(const google::protobuf::MessageLite& message);

void to_proto(const Vec3d& v, v1::Vec3* out);
void to_proto(const Pose& pose, v1::Pose* out);
v1::DeviceState to_proto(rt::DeviceState state);
Vec3d from_proto(const v1::Vec3& v);
Pose from_proto(const v1::Pose& pose);

// A HapticFrame for a snapshot (device state included), with its contacts when `contacts`.
void fill_frame(const rt::Snapshot& snapshot, bool contacts, v1::HapticFrame* out);

struct ClientCheck {
  bool ok = true;
  v1::Error::Code code = v1::Error::UNKNOWN;
  std::string reason;
};

// Parses one frame body as a ClientMessage and checks it: an envelope with exactly one message,
// strings within kMaxNameBytes, finite numbers, unit-ish quaternions (|q| in [0.5, 2]), a
// non-negative frame rate. Pure: the fuzz target drives it directly.
ClientCheck parse_client_message(std::string_view body, v1::ClientMessage& out);

}  // namespace palp::net
