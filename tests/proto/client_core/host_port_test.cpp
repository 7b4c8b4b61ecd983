// HOST:PORT as palpview, palp probe and palp ctl read it (proto/client_core/host_port.cpp).
#include "client_core/host_port.hpp"

#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "base/errors.hpp"

namespace palp {
namespace {

TEST(ParseHostPort, AcceptsHostsAndBracketedIpv6) {
  std::string host;
  std::uint16_t port = 0;
  client::parse_host_port("127.0.0.1:7400", host, port);
  EXPECT_EQ(host, "127.0.0.1");
  EXPECT_EQ(port, 7400);
  client::parse_host_port("lab-pc.example:1", host, port);
  EXPECT_EQ(host, "lab-pc.example");
  EXPECT_EQ(port, 1);
  client::parse_host_port("[::1]:65535", host, port);
  EXPECT_EQ(host, "::1");
  EXPECT_EQ(port, 65535);
}

TEST(ParseHostPort, RejectsMalformedInputWithTheReason) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "missing ':PORT'"},
      {"localhost", "missing ':PORT'"},
      {"localhost:", "empty port"},
      {":7400", "empty host"},
      {"localhost:0", "out of range"},
      {"localhost:65536", "out of range"},
      {"localhost:1234567", "out of range"},
      {"localhost:74a0", "not a number"},
      {"localhost:+80", "not a number"},
      {"localhost: 80", "not a number"},
      {"::1:7400", "brackets"},
      {"[::1]7400", "missing ':PORT'"},
      {"[::1", "missing ']'"},
      {"[localhost]:80", "brackets are for IPv6"},
      {"[]:80", "brackets are for IPv6"},
      {"bad host:80", "invalid character"},
  };
  for (const auto& [text, why] : cases) {
    std::string host = "unchanged";
    std::uint16_t port = 9;
    try {
      client::parse_host_port(text, host, port);
      ADD_FAILURE() << "accepted '" << text << "'";
    } catch (const UsageError& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << text << ": " << e.what();
      EXPECT_NE(std::string(e.what()).find("'" + text + "'"), std::string::npos) << e.what();
    }
    EXPECT_EQ(host, "unchanged");
    EXPECT_EQ(port, 9);
  }
}

TEST(ParseHostPort, SaysWhyWithoutThrowing) {
  std::string host = "unchanged";
  std::uint16_t port = 9;
  EXPECT_EQ(client::host_port_problem("localhost", host, port), "missing ':PORT'");
  EXPECT_EQ(host, "unchanged");
  EXPECT_EQ(client::host_port_problem("[fe80::1]:7400", host, port), "");
  EXPECT_EQ(host, "fe80::1");
  EXPECT_EQ(port, 7400);
}

TEST(FormatHostPort, BracketsIpv6AndReadsBack) {
  EXPECT_EQ(client::format_host_port("127.0.0.1", 7400), "127.0.0.1:7400");
  EXPECT_EQ(client::format_host_port("::1", 1), "[::1]:1");
  std::string host;
  std::uint16_t port = 0;
  client::parse_host_port(client::format_host_port("::1", 65535), host, port);
  EXPECT_EQ(host, "::1");
  EXPECT_EQ(port, 65535);
}

}  // namespace
}  // namespace palp
