// palp.v1 -> palpview's structs (client/stream/frame_decoding.cpp) for what the structure layers
// add: the pulse on every frame, kept to its ranges, unset from an older palpd; the scene's
// structures, at most 64 with increasing labels and names within the limit.
#include "stream/frame_decoding.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "stream/protocol_checks.hpp"

namespace palp::view::net {
namespace {

v1::SceneInfo scene_info() {
  v1::SceneInfo s;
  for (int a = 0; a < 3; ++a) {
    s.mutable_grid()->add_dims(8);
    s.mutable_grid()->add_spacing(2.0);
  }
  return s;
}

TEST(FrameDecoding, ThePulseOnAFrame) {
  v1::HapticFrame f;
  EXPECT_FALSE(decode_frame(f).pulse_bpm);  // an older palpd: the rate is not said
  EXPECT_EQ(decode_frame(f).pulse_wave, 0.0);
  f.set_pulse_wave(0.75f);
  f.set_pulse_force(0.5f);
  f.set_organ_force(2.0f);
  f.set_pulse_bpm(0.0f);  // said: no pulse
  FrameState frame = decode_frame(f);
  EXPECT_EQ(frame.pulse_wave, 0.75);
  EXPECT_EQ(frame.pulse_force, 0.5);
  EXPECT_EQ(frame.organ_force, 2.0);
  ASSERT_TRUE(frame.pulse_bpm);
  EXPECT_EQ(*frame.pulse_bpm, 0.0);
  // Out of range or not finite: kept to 0..1 (the wave), 0 (the rest).
  f.set_pulse_wave(7.0f);
  f.set_pulse_force(std::numeric_limits<float>::quiet_NaN());
  f.set_organ_force(-3.0f);
  f.set_pulse_bpm(std::numeric_limits<float>::infinity());
  frame = decode_frame(f);
  EXPECT_EQ(frame.pulse_wave, 1.0);
  EXPECT_EQ(frame.pulse_force, 0.0);
  EXPECT_EQ(frame.organ_force, 0.0);
  EXPECT_EQ(*frame.pulse_bpm, 0.0);
}

TEST(FrameDecoding, TheScenesStructures) {
  v1::SceneInfo s = scene_info();
  EXPECT_TRUE(decode_scene(s)->structures.empty());  // an older palpd, or none
  for (const char* name : {"vessel", "artery", "liver"}) {
    v1::Structure* st = s.add_structures();
    st->set_label(static_cast<std::uint32_t>(s.structures_size()));
    st->set_name(name);
    st->set_kind(std::string(name) == "liver" ? "organ" : name);
  }
  s.mutable_parameters()->set_pulse_bpm(66.0);
  const auto scene = decode_scene(s);
  ASSERT_EQ(scene->structures.size(), 3u);
  EXPECT_EQ(scene->structures[1].label, 2);
  EXPECT_EQ(scene->structures[1].name, "artery");
  EXPECT_EQ(scene->structures[2].kind, "organ");
  EXPECT_EQ(scene->pulse_bpm, 66.0);
  // Labels must increase within 1..64; at most 64 structures; names at most 256 bytes.
  v1::SceneInfo repeated = s;
  repeated.mutable_structures(2)->set_label(2);
  EXPECT_THROW(decode_scene(repeated), ProtocolViolation);
  v1::SceneInfo over = s;
  over.mutable_structures(2)->set_label(65);
  EXPECT_THROW(decode_scene(over), ProtocolViolation);
  v1::SceneInfo zero = s;
  zero.mutable_structures(0)->set_label(0);
  EXPECT_THROW(decode_scene(zero), ProtocolViolation);
  v1::SceneInfo long_name = s;
  long_name.mutable_structures(0)->set_name(std::string(257, 'a'));
  EXPECT_THROW(decode_scene(long_name), ProtocolViolation);
  v1::SceneInfo many = scene_info();
  for (std::uint32_t l = 1; l <= 65; ++l) many.add_structures()->set_label(l);
  EXPECT_THROW(decode_scene(many), ProtocolViolation);
  many.mutable_structures()->RemoveLast();
  EXPECT_EQ(decode_scene(many)->structures.size(), 64u);
}

}  // namespace
}  // namespace palp::view::net
