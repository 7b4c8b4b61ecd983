// What a client may send before it connects (proto/tls/client_policy.cpp), decided once for palp
// probe, palp ctl and palpview: a token crosses the network in clear text only to loopback
// (127.0.0.0/8, ::1; a name is judged by what it resolves to), and a client certificate without
// --tls-ca/--tls-pin is refused instead of going unused over plain text.
#include "tls/client_policy.hpp"

#include <gtest/gtest.h>

#include "base/errors.hpp"

namespace palp::tls {
namespace {

using asio::ip::tcp;

// What `host` resolves to (numeric hosts need no name service; "localhost" comes from
// /etc/hosts).
tcp::resolver::results_type resolved(const std::string& host) {
  static asio::io_context io;
  tcp::resolver resolver(io);
  return resolver.resolve(host, "7400", tcp::resolver::flags());  // IPv6 literals here too
}

std::string refusal_for(const std::string& host, bool has_token = true, bool tls = false) {
  return clear_text_token_refusal(has_token, tls, host, resolved(host));
}

TEST(ClearTextToken, OnlyLoopbackMayReceiveIt) {
  for (const char* loopback : {"127.0.0.1", "127.8.9.10", "::1", "::ffff:127.0.0.1", "localhost"})
    EXPECT_EQ(refusal_for(loopback), "") << loopback;
  for (const char* outside :
       {"10.0.0.7", "192.0.2.1", "128.0.0.1", "::ffff:10.0.0.7", "2001:db8::1", "0.0.0.0"}) {
    const std::string no = refusal_for(outside);
    EXPECT_NE(no.find("clear text"), std::string::npos) << outside << ": " << no;
    EXPECT_NE(no.find("--tls-ca"), std::string::npos) << outside << ": " << no;
    EXPECT_NE(no.find("--tls-pin"), std::string::npos) << outside << ": " << no;
    EXPECT_NE(no.find(outside), std::string::npos) << outside << ": " << no;
  }
}

TEST(ClearTextToken, NoTokenOrTlsMayGoAnywhere) {
  EXPECT_EQ(refusal_for("192.0.2.1", false, false), "");
  EXPECT_EQ(refusal_for("192.0.2.1", true, true), "");
}

// A name that resolves to loopback and to another machine may reach either: refused.
TEST(ClearTextToken, AnyAddressBeyondLoopbackRefusesIt) {
  const std::vector<tcp::endpoint> both = {{asio::ip::make_address("127.0.0.1"), 7400},
                                           {asio::ip::make_address("10.0.0.7"), 7400}};
  const auto endpoints =
      tcp::resolver::results_type::create(both.begin(), both.end(), "station", "7400");
  const std::string no = clear_text_token_refusal(true, false, "station", endpoints);
  EXPECT_NE(no.find("'station' (10.0.0.7)"), std::string::npos) << no;
  EXPECT_NE(clear_text_token_refusal(true, false, "nowhere", {}), "");
}

TEST(ClientOptions, ACertificateNeedsTlsAndItsKey) {
  EXPECT_NO_THROW(check_client_options({}));
  EXPECT_NO_THROW(check_client_options({"ca.crt", "", "", ""}));
  EXPECT_NO_THROW(check_client_options({"ca.crt", "", "station.crt", "station.key"}));
  EXPECT_NO_THROW(check_client_options({"", "AB:CD", "station.crt", "station.key"}));
  for (const ClientOptions& plain :
       {ClientOptions{"", "", "station.crt", "station.key"},
        ClientOptions{"", "", "station.crt", ""}, ClientOptions{"", "", "", "station.key"}}) {
    try {
      check_client_options(plain);
      ADD_FAILURE() << "a certificate without --tls-ca/--tls-pin was accepted";
    } catch (const UsageError& e) {
      EXPECT_NE(std::string(e.what()).find("--tls-ca"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("--tls-pin"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(check_client_options({"ca.crt", "", "station.crt", ""}), UsageError);
}

}  // namespace
}  // namespace palp::tls
