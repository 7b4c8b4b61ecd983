// The text side of stream_client.hpp: the names of link and device states (HOST:PORT is parsed
// by the client core, proto/client_core/host_port.hpp).
#include "stream/stream_client.hpp"

#include <string>

namespace palp::view {

const char* to_string(LinkState state) {
  switch (state) {
    case LinkState::Connecting:
      return "connecting";
    case LinkState::Loading:
      return "loading";
    case LinkState::Live:
      return "live";
    case LinkState::Stalled:
      return "stalled";
    case LinkState::Reconnecting:
      return "reconnecting";
    case LinkState::Refused:
      break;
  }
  return "refused";
}

const char* to_string(DeviceState state) {
  switch (state) {
    case DeviceState::Present:
      return "present";
    case DeviceState::Absent:
      return "absent";
    case DeviceState::Fault:
      return "fault";
    case DeviceState::Unknown:
      break;
  }
  return "unknown";
}

}  // namespace palp::view
