// palp.v1 on palpd's side: snapshots into HapticFrames, and the checks every client message
// passes. The shared helpers (framing, vectors, poses) are in proto/wire.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "palp.pb.h"
#include "rt/snapshot.hpp"
#include "wire/messages.hpp"

namespace palp::net {

using wire::kMaxNameBytes;
using wire::kProtocolVersion;
using wire::to_proto;  // the device state among them (proto/wire/messages.hpp)

// A ServerMessage's frame, shared by every client it is queued for; one holding an Error.
std::shared_ptr<const std::string> frame_of(const v1::ServerMessage& message);
std::shared_ptr<const std::string> error_frame(v1::Error::Code code, const std::string& reason,
                                               bool fatal);

// The Welcome for a client, and the Pong for its Ping (`now_ns`: the server's clock).
std::shared_ptr<const std::string> welcome_frame(std::uint64_t client_id, v1::Role role,
                                                 const std::string& server_name, double rate_hz,
                                                 std::int64_t now_ns);
std::shared_ptr<const std::string> pong_frame(const v1::Ping& ping, std::int64_t now_ns);

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
