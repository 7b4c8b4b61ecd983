// See message_reader.hpp.
#include "client_core/message_reader.hpp"

#include <string_view>

namespace palp::client {

ServerMessageReader::Next ServerMessageReader::next(v1::ServerMessage& m, std::string& why) {
  std::string_view body;
  const wire::FrameStatus status = decoder_.next(body);
  if (status == wire::FrameStatus::Incomplete) return Next::Incomplete;
  if (status != wire::FrameStatus::Ok) {
    why = "bad frame from " + peer_ + ": " + wire::to_string(status);
    return Next::Broken;
  }
  if (!m.ParseFromArray(body.data(), static_cast<int>(body.size()))) {
    why = "undecodable message from " + peer_;
    return Next::Broken;
  }
  return Next::Message;
}

}  // namespace palp::client
