// palpd's side of palp.v1: snapshots into frames, and the checks of client messages (including
// mutated ones: parse_client_message is what the fuzz target drives).
#include "net/protocol.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "wire/framing.hpp"

namespace palp::net {
namespace {

v1::ClientMessage hello() {
  v1::ClientMessage m;
  v1::Hello* h = m.mutable_hello();
  h->set_protocol_version(kProtocolVersion);
  h->set_role(v1::OBSERVER);
  h->set_client_name("test");
  return m;
}

TEST(Protocol, FramesAreDelimitedMessages) {
  const v1::ClientMessage m = hello();
  const std::string frame = wire::encode_frame(m);
  wire::FrameDecoder d;
  d.feed(reinterpret_cast<const std::uint8_t*>(frame.data()), frame.size());
  std::string_view body;
  ASSERT_EQ(d.next(body), wire::FrameStatus::Ok);
  v1::ClientMessage back;
  const ClientCheck c = parse_client_message(body, back);
  EXPECT_TRUE(c.ok) << c.reason;
  EXPECT_EQ(back.hello().client_name(), "test");
}

TEST(Protocol, FrameCarriesTheSnapshot) {
  rt::Snapshot s;
  s.tick.seq = 42;
  s.tick.t_ns = 123456789;
  s.tick.force = {1, 2, 3};
  s.tick.n_contact = 2;
  s.tick.fault = 4;
  s.contact_points = 7;
  s.contacts.resize(2);
  s.contacts[1].in_contact = 1;
  s.contacts[1].p = {9, 8, 7};
  s.contact_count = 2;
  v1::HapticFrame f;
  fill_frame(s, false, &f);
  EXPECT_EQ(f.seq(), 42u);
  EXPECT_EQ(f.server_time_ns(), 123456789);
  EXPECT_EQ(f.force().z(), 3.0);
  EXPECT_EQ(f.n_contact(), 2u);
  EXPECT_EQ(f.fault(), 4u);
  EXPECT_EQ(f.contact_points(), 7u);
  EXPECT_EQ(f.contacts_size(), 0);
  f.Clear();
  fill_frame(s, true, &f);
  ASSERT_EQ(f.contacts_size(), 2);
  EXPECT_TRUE(f.contacts(1).in_contact());
  EXPECT_EQ(f.contacts(1).proxy().x(), 9.0);
  EXPECT_EQ(f.device_state(), v1::DEVICE_PRESENT);
  s.device_state = rt::DeviceState::Absent;
  fill_frame(s, false, &f);
  EXPECT_EQ(f.device_state(), v1::DEVICE_ABSENT);
  s.device_state = rt::DeviceState::Fault;
  fill_frame(s, false, &f);
  EXPECT_EQ(f.device_state(), v1::DEVICE_FAULT);
}

// The structure layers ride on every frame: the pulse's wave and rate, |f_pulse| and |f_organ|,
// through the wire and back (float fields: the values below are exact in float).
TEST(Protocol, FrameCarriesThePulse) {
  rt::Snapshot s;
  s.pulse_wave = 0.375f;
  s.pulse_force_N = 0.25f;
  s.organ_force_N = 1.5f;
  s.pulse_bpm = 84.0f;
  v1::ServerMessage m;
  fill_frame(s, false, m.mutable_frame());
  const std::string frame = wire::encode_frame(m);
  wire::FrameDecoder d;
  d.feed(reinterpret_cast<const std::uint8_t*>(frame.data()), frame.size());
  std::string_view body;
  ASSERT_EQ(d.next(body), wire::FrameStatus::Ok);
  v1::ServerMessage back;
  ASSERT_TRUE(back.ParseFromArray(body.data(), static_cast<int>(body.size())));
  const v1::HapticFrame& f = back.frame();
  EXPECT_EQ(f.pulse_wave(), 0.375f);
  EXPECT_EQ(f.pulse_force(), 0.25f);
  EXPECT_EQ(f.organ_force(), 1.5f);
  ASSERT_TRUE(f.has_pulse_bpm());  // said even at 0 (no pulse), unlike an older server
  EXPECT_EQ(f.pulse_bpm(), 84.0f);
  s.pulse_bpm = 0;
  m.Clear();
  fill_frame(s, false, m.mutable_frame());
  EXPECT_TRUE(m.frame().has_pulse_bpm());
  // Four float fields, 4 bytes each after their tags (field 15's tag one byte, 16..18's two:
  // numbers of 16 and above need a second varint byte): 23 bytes more a frame at most.
  v1::HapticFrame without = m.frame();
  without.clear_pulse_wave(), without.clear_pulse_force(), without.clear_organ_force();
  without.clear_pulse_bpm();
  m.mutable_frame()->set_pulse_bpm(84.0f);
  EXPECT_EQ(m.frame().ByteSizeLong() - without.ByteSizeLong(), 23u);
}

TEST(Protocol, ChecksClientMessages) {
  v1::ClientMessage out;
  const auto check = [&](const v1::ClientMessage& m) {
    return parse_client_message(m.SerializeAsString(), out);
  };
  EXPECT_FALSE(check(v1::ClientMessage{}).ok);  // empty envelope
  v1::ClientMessage m = hello();
  m.mutable_hello()->set_role(v1::ROLE_UNSPECIFIED);
  EXPECT_EQ(check(m).code, v1::Error::BAD_REQUEST);
  m = hello();
  m.mutable_hello()->set_frame_rate_hz(-1);
  EXPECT_FALSE(check(m).ok);
  m.mutable_hello()->set_frame_rate_hz(NAN);
  EXPECT_FALSE(check(m).ok);
  m = hello();
  m.mutable_hello()->set_client_name(std::string(kMaxNameBytes + 1, 'n'));
  EXPECT_FALSE(check(m).ok);
  v1::ClientMessage pose;
  pose.mutable_device_pose()->mutable_pose()->mutable_position()->set_x(INFINITY);
  EXPECT_FALSE(check(pose).ok);
  pose.mutable_device_pose()->mutable_pose()->mutable_position()->set_x(1);
  EXPECT_TRUE(check(pose).ok);
  pose.mutable_device_pose()->mutable_pose()->mutable_orientation()->set_w(0.1);
  EXPECT_FALSE(check(pose).ok);
  v1::ClientMessage command;
  command.mutable_command()->set_request_id(1);
  EXPECT_FALSE(check(command).ok);  // no kind
  command.mutable_command()->mutable_set_parameter()->set_name("k");
  command.mutable_command()->mutable_set_parameter()->set_value(NAN);
  EXPECT_FALSE(check(command).ok);
  command.mutable_command()->mutable_set_parameter()->set_value(0.5);
  EXPECT_TRUE(check(command).ok);
  const std::string garbage = "\xff\xff\xff";
  const ClientCheck g = parse_client_message(garbage, out);
  EXPECT_FALSE(g.ok);
  EXPECT_EQ(g.code, v1::Error::MALFORMED);
}

// Valid messages with random bytes flipped, cut and spliced: parsing never crashes and whatever
// passes the checks is usable (finite numbers where it matters).
TEST(Protocol, MutatedMessagesAreRejectedOrSafe) {
  std::mt19937_64 rng(7);
  std::vector<std::string> seeds;
  seeds.push_back(hello().SerializeAsString());
  v1::ClientMessage c;
  c.mutable_command()->mutable_set_tool()->set_tool("finger:19");
  seeds.push_back(c.SerializeAsString());
  v1::ClientMessage p;
  p.mutable_device_pose()->mutable_pose()->mutable_position()->set_z(50);
  p.mutable_device_pose()->mutable_pose()->mutable_orientation()->set_w(1);
  seeds.push_back(p.SerializeAsString());
  int accepted = 0;
  for (int round = 0; round < 20000; ++round) {
    std::string body = seeds[rng() % seeds.size()];
    const int mutations = 1 + static_cast<int>(rng() % 4);
    for (int m = 0; m < mutations && !body.empty(); ++m) {
      const std::size_t at = rng() % body.size();
      switch (rng() % 4) {
        case 0:
          body[at] = static_cast<char>(body[at] ^ (1 << (rng() % 8)));
          break;
        case 1:
          body.resize(at);
          break;
        case 2:
          body.insert(at, 1, static_cast<char>(rng()));
          break;
        default:
          body[at] = static_cast<char>(rng());
          break;
      }
    }
    v1::ClientMessage out;
    const ClientCheck check = parse_client_message(body, out);
    if (!check.ok) continue;
    ++accepted;
    if (out.has_device_pose()) {
      const Pose pose = wire::from_proto(out.device_pose().pose());
      ASSERT_TRUE(is_finite(pose.position));
    }
    if (out.has_hello()) {
      ASSERT_TRUE(std::isfinite(out.hello().frame_rate_hz()));
      ASSERT_LE(out.hello().client_name().size(), kMaxNameBytes);
    }
  }
  EXPECT_GT(accepted, 0);
}

}  // namespace
}  // namespace palp::net
