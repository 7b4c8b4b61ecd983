// The palp.v1 helpers both ends share: a message's frame, and poses through their protobuf form.
#include "wire/messages.hpp"

#include <gtest/gtest.h>

#include "wire/framing.hpp"

namespace palp::wire {
namespace {

TEST(Messages, FrameIsTheVarintLengthThenTheBody) {
  v1::ClientMessage m;
  m.mutable_hello()->set_client_name(std::string(200, 'x'));  // body over 127 bytes: 2-byte prefix
  const std::string frame = encode_frame(m);
  const std::string body = m.SerializeAsString();
  ASSERT_GT(body.size(), 127u);
  ASSERT_EQ(frame.size(), body.size() + 2);
  EXPECT_EQ(static_cast<std::uint8_t>(frame[0]), 0x80u | (body.size() & 0x7Fu));
  EXPECT_EQ(static_cast<std::uint8_t>(frame[1]), body.size() >> 7);
  EXPECT_EQ(frame.substr(2), body);
}

TEST(Messages, DeviceStatesKeepTheirNumbers) {
  for (const DeviceState s : {DeviceState::Present, DeviceState::Absent, DeviceState::Fault}) {
    EXPECT_EQ(static_cast<int>(to_proto(s)), static_cast<int>(s));
    EXPECT_EQ(from_proto(to_proto(s)), s);
  }
  EXPECT_EQ(to_proto(DeviceState::Unknown), v1::DEVICE_STATE_UNSPECIFIED);
  EXPECT_EQ(from_proto(v1::DEVICE_STATE_UNSPECIFIED), DeviceState::Unknown);
  EXPECT_EQ(from_proto(static_cast<v1::DeviceState>(9)), DeviceState::Unknown);
}

TEST(Messages, PosesRoundTrip) {
  Pose p;
  p.position = {1.5, -2, 1e-9};
  p.orientation = {0.5, -0.5, 0.5, 0.5};
  v1::Pose message;
  to_proto(p, &message);
  const Pose back = from_proto(message);
  EXPECT_EQ(back.position, p.position);
  EXPECT_EQ(back.orientation, p.orientation);
  EXPECT_EQ(from_proto(v1::Pose{}).orientation, Quat{});  // no orientation: identity
}

}  // namespace
}  // namespace palp::wire
