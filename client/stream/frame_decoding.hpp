// palp.v1 -> plain structs (pure, no Asio): SceneInfo and HapticFrame (the device state by
// proto/wire's from_proto).
#pragma once

#include <memory>

#include "palp.pb.h"
#include "stream/stream_client.hpp"

namespace palp::view::net {

// The scene the server describes; server_name is left empty (it comes with Welcome). Throws
// ProtocolViolation when the grid is unusable (not 3 dims and spacings, out of range).
std::shared_ptr<SceneDescription> decode_scene(const v1::SceneInfo& s);

// A haptic frame, valid, with its contacts.
FrameState decode_frame(const v1::HapticFrame& f);

}  // namespace palp::view::net
