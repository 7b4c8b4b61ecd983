// palpview's network layer (client/stream/stream_client): what needs no server. Unusable options
// are refused when the client is made; a token for another machine without TLS is refused before
// anything connects. Against palpd: stream_client_palpd_test.cpp; against scripted servers:
// stream_client_fake_server_test.cpp; over TLS: stream_client_tls_test.cpp.
#include "stream/stream_client.hpp"

#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "base/errors.hpp"
#include "support/stream_client_waits.hpp"

namespace palp {
namespace {

using testing::is_state;
using testing::options_for;
using testing::wait_for;
using view::LatestState;
using view::LinkState;
using view::StreamClient;
using view::StreamOptions;

TEST(StreamClient, RejectsUnusableOptions) {
  StreamOptions o;
  o.port = 0;
  EXPECT_THROW(StreamClient{o}, UsageError);
  o = StreamOptions{};
  o.stall_s = 0;
  EXPECT_THROW(StreamClient{o}, UsageError);
  o = StreamOptions{};
  o.reconnect_max_s = o.reconnect_min_s / 2;
  EXPECT_THROW(StreamClient{o}, UsageError);
  o = StreamOptions{};
  o.frame_rate_hz = -1;
  EXPECT_THROW(StreamClient{o}, UsageError);
  o = StreamOptions{};
  o.token = std::string(300, 't');
  EXPECT_THROW(StreamClient{o}, UsageError);
  EXPECT_STREQ(view::to_string(LinkState::Stalled), "stalled");
  EXPECT_STREQ(view::to_string(view::DeviceState::Absent), "absent");
}

// A token for another machine without TLS is never sent: the client goes Refused before it
// connects, naming --tls-ca and --tls-pin; to loopback, or without a token, it may connect. A
// certificate without TLS is refused when the client is made.
TEST(StreamClient, ATokenForAnotherMachineWithoutTlsIsRefusedBeforeConnecting) {
  StreamOptions o;
  o.host = "192.0.2.1";  // TEST-NET-1: nothing answers, a client that tried would keep trying
  o.controller = true;
  o.token = "s3cret";
  EXPECT_NE(connect_refusal(o).find("--tls-ca"), std::string::npos) << connect_refusal(o);
  StreamClient client(o);
  client.start();
  const LatestState s = wait_for(
      client, [](const LatestState& l) { return is_state(l, LinkState::Refused); }, 10.0);
  EXPECT_EQ(s.link.state, LinkState::Refused) << s.link.message;
  EXPECT_NE(s.link.message.find("clear text"), std::string::npos) << s.link.message;
  EXPECT_NE(s.link.message.find("--tls-pin"), std::string::npos) << s.link.message;
  EXPECT_EQ(s.link.connections, 0u);
  client.stop();
  o.host = "127.0.0.1";
  EXPECT_EQ(connect_refusal(o), "");
  o.host = "localhost";
  EXPECT_EQ(connect_refusal(o), "");
  o.host = "192.0.2.1";
  o.token.clear();
  EXPECT_EQ(connect_refusal(o), "");
  o.tls_cert = "station.crt";
  o.tls_key = "station.key";
  EXPECT_THROW(StreamClient{o}, UsageError);
}

}  // namespace
}  // namespace palp
