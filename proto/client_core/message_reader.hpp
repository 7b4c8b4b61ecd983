// The ServerMessages in the bytes a palp.v1 client reads, decoded as they come (pure, no Asio):
// palpview's connection thread and the consoles' ServerLink feed it what each read returns.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>

#include "palp.pb.h"
#include "wire/framing.hpp"

namespace palp::client {

class ServerMessageReader {
 public:
  enum class Next { Message, Incomplete, Broken };

  // `peer` names the server in the reasons ("the server", "palpd").
  explicit ServerMessageReader(std::string peer,
                               std::size_t max_frame = wire::kDefaultMaxServerFrame)
      : peer_(std::move(peer)), decoder_(max_frame) {}

  void feed(const std::uint8_t* data, std::size_t n) { decoder_.feed(data, n); }

  // Message: `m` holds the next message. Incomplete: wait for more bytes. Broken: the stream
  // cannot go on (a bad frame, an undecodable message); `why` says so, naming the peer.
  Next next(v1::ServerMessage& m, std::string& why);

 private:
  std::string peer_;
  wire::FrameDecoder decoder_;
};

}  // namespace palp::client
