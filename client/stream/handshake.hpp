// The Hello handshake (pure, no Asio): the Hello, the Welcome check, which Errors are refusals.
#pragma once

#include <string>

#include "palp.pb.h"
#include "stream/stream_client.hpp"

namespace palp::view::net {

// The Hello frame (varint prefix + message) asking for what `opts` say.
std::string encode_hello(const StreamOptions& opts);

// Empty when this client can talk to the server that sent `w`, else why not (the protocol
// version): the client refuses the connection with it.
std::string welcome_refusal(const v1::Welcome& w);

// Fatal Errors that retrying cannot fix: the client asked for something the server will refuse
// again. Everything else (timeouts, a full server, shutting down) is retried.
bool is_refusal(v1::Error::Code code);

}  // namespace palp::view::net
