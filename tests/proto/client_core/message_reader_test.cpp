// The server's messages decoded as the bytes come (proto/client_core/message_reader.cpp), as
// palpview's connection thread and palp probe / palp ctl read them.
#include "client_core/message_reader.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>

#include "wire/framing.hpp"
#include "wire/messages.hpp"

namespace palp {
namespace {

using Next = client::ServerMessageReader::Next;

void feed(client::ServerMessageReader& r, const std::string& bytes) {
  r.feed(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
}

TEST(ServerMessageReader, DecodesMessagesSplitAcrossReads) {
  v1::ServerMessage a, b;
  a.mutable_welcome()->set_server_name("palpd");
  b.mutable_pong()->set_id(7);
  const std::string bytes = wire::encode_frame(a) + wire::encode_frame(b);
  client::ServerMessageReader r("the server");
  v1::ServerMessage m;
  std::string why;
  feed(r, bytes.substr(0, 3));
  EXPECT_EQ(r.next(m, why), Next::Incomplete);
  feed(r, bytes.substr(3));
  ASSERT_EQ(r.next(m, why), Next::Message);
  EXPECT_EQ(m.welcome().server_name(), "palpd");
  ASSERT_EQ(r.next(m, why), Next::Message);
  EXPECT_EQ(m.pong().id(), 7u);
  EXPECT_FALSE(m.has_welcome());  // each message replaces the last
  EXPECT_EQ(r.next(m, why), Next::Incomplete);
  EXPECT_EQ(why, "");
}

TEST(ServerMessageReader, NamesThePeerWhenTheStreamBreaks) {
  client::ServerMessageReader bad_prefix("palpd");
  feed(bad_prefix, std::string(11, '\xff'));
  v1::ServerMessage m;
  std::string why;
  EXPECT_EQ(bad_prefix.next(m, why), Next::Broken);
  EXPECT_EQ(why, std::string("bad frame from palpd: ") +
                     wire::to_string(wire::FrameStatus::BadPrefix));

  client::ServerMessageReader too_large("the server", 16);
  feed(too_large, wire::encode_frame([] {
         v1::ServerMessage big;
         big.mutable_welcome()->set_server_name(std::string(64, 'x'));
         return big;
       }()));
  EXPECT_EQ(too_large.next(m, why), Next::Broken);
  EXPECT_EQ(why, std::string("bad frame from the server: ") +
                     wire::to_string(wire::FrameStatus::TooLarge));

  client::ServerMessageReader garbage("the server");
  feed(garbage, std::string("\x03\xff\xff\xff", 4));  // a 3-byte body that is no message
  EXPECT_EQ(garbage.next(m, why), Next::Broken);
  EXPECT_EQ(why, "undecodable message from the server");
}

}  // namespace
}  // namespace palp
