// The text side of stream_client.hpp: the names of link and device states, and HOST:PORT parsing.
#include "stream/stream_client.hpp"

#include <string>

#include "base/errors.hpp"

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

void parse_host_port(const std::string& text, std::string& host, std::uint16_t& port) {
  const auto bad = [&](const std::string& why) {
    return UsageError("expected HOST:PORT, got '" + text + "': " + why);
  };
  std::string host_part, port_part;
  if (!text.empty() && text.front() == '[') {
    const auto close = text.find(']');
    if (close == std::string::npos) throw bad("missing ']'");
    host_part = text.substr(1, close - 1);
    if (close + 1 >= text.size() || text[close + 1] != ':') throw bad("missing ':PORT'");
    port_part = text.substr(close + 2);
    if (host_part.find(':') == std::string::npos) throw bad("brackets are for IPv6 addresses");
  } else {
    const auto colon = text.rfind(':');
    if (colon == std::string::npos) throw bad("missing ':PORT'");
    host_part = text.substr(0, colon);
    port_part = text.substr(colon + 1);
    if (host_part.find(':') != std::string::npos)
      throw bad("write an IPv6 address in brackets: [ADDRESS]:PORT");
  }
  if (host_part.empty()) throw bad("empty host");
  for (const char c : host_part)
    if (static_cast<unsigned char>(c) <= ' ' || c == '[' || c == ']' || c == '/')
      throw bad("invalid character in the host");
  if (port_part.empty()) throw bad("empty port");
  if (port_part.size() > 5) throw bad("port out of range 1..65535");
  unsigned value = 0;
  for (const char c : port_part) {
    if (c < '0' || c > '9') throw bad("the port is not a number");
    value = value * 10 + static_cast<unsigned>(c - '0');
  }
  if (value < 1 || value > 65535) throw bad("port out of range 1..65535");
  host = host_part;
  port = static_cast<std::uint16_t>(value);
}

}  // namespace palp::view
