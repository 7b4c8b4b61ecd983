// HOST:PORT: see host_port.hpp.
#include "client_core/host_port.hpp"

#include "base/errors.hpp"

namespace palp::client {

namespace {

// Splits `text` into its host and port parts; "" or why not.
std::string split_host_port(const std::string& text, std::string& host_part,
                            std::string& port_part) {
  if (!text.empty() && text.front() == '[') {
    const auto close = text.find(']');
    if (close == std::string::npos) return "missing ']'";
    host_part = text.substr(1, close - 1);
    if (close + 1 >= text.size() || text[close + 1] != ':') return "missing ':PORT'";
    port_part = text.substr(close + 2);
    if (host_part.find(':') == std::string::npos) return "brackets are for IPv6 addresses";
    return "";
  }
  const auto colon = text.rfind(':');
  if (colon == std::string::npos) return "missing ':PORT'";
  host_part = text.substr(0, colon);
  port_part = text.substr(colon + 1);
  if (host_part.find(':') != std::string::npos)
    return "write an IPv6 address in brackets: [ADDRESS]:PORT";
  return "";
}

}  // namespace

std::string host_port_problem(const std::string& text, std::string& host, std::uint16_t& port) {
  std::string host_part, port_part;
  if (std::string why = split_host_port(text, host_part, port_part); !why.empty()) return why;
  if (host_part.empty()) return "empty host";
  for (const char c : host_part)
    if (static_cast<unsigned char>(c) <= ' ' || c == '[' || c == ']' || c == '/')
      return "invalid character in the host";
  if (port_part.empty()) return "empty port";
  if (port_part.size() > 5) return "port out of range 1..65535";
  unsigned value = 0;
  for (const char c : port_part) {
    if (c < '0' || c > '9') return "the port is not a number";
    value = value * 10 + static_cast<unsigned>(c - '0');
  }
  if (value < 1 || value > 65535) return "port out of range 1..65535";
  host = host_part;
  port = static_cast<std::uint16_t>(value);
  return "";
}

void parse_host_port(const std::string& text, std::string& host, std::uint16_t& port) {
  if (const std::string why = host_port_problem(text, host, port); !why.empty())
    throw UsageError("expected HOST:PORT, got '" + text + "': " + why);
}

std::string format_host_port(const std::string& host, std::uint16_t port) {
  return (host.find(':') != std::string::npos ? "[" + host + "]" : host) + ":" +
         std::to_string(port);
}

}  // namespace palp::client
