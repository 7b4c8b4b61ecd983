// palpd's address as every palp.v1 client writes it: "HOST:PORT", an IPv6 address in brackets
// ("[::1]:7400"). One parser for palpview (--connect), palp probe and palp ctl.
#pragma once

#include <cstdint>
#include <string>

namespace palp::client {

// "" when `text` is HOST:PORT (then `host` and `port`, 1..65535, are set); otherwise why not
// ("missing ':PORT'", "port out of range 1..65535", ...), and `host` and `port` are untouched.
std::string host_port_problem(const std::string& text, std::string& host, std::uint16_t& port);

// The same, throwing UsageError("expected HOST:PORT, got 'TEXT': why") when malformed.
void parse_host_port(const std::string& text, std::string& host, std::uint16_t& port);

// host and port written back as HOST:PORT (an IPv6 address in brackets).
std::string format_host_port(const std::string& host, std::uint16_t port);

}  // namespace palp::client
