// Round trips of every topic type through Cyclone on loopback, late joiners, rig separation and
// the rig list. Each test its own domain (support/dds_loopback.hpp).
#include "dds_subscriber.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "support/dds_loopback.hpp"

namespace palp::dds {
namespace {

using palp::testing::unique_dds_domain;

// A writer of `desc` on `name` with the QoS of `kind`.
dds_entity_t writer(dds_entity_t participant, const dds_topic_descriptor_t* desc,
                    const std::string& name, QosKind kind, std::int32_t depth) {
  const dds_entity_t topic = make_topic(participant, desc, name);
  const QosPtr qos = make_qos(kind, depth);
  return checked(dds_create_writer(participant, topic, qos.get(), nullptr), "writer");
}

// Waits until `w` has matched `n` readers (discovery), at most 10 s.
bool matched(dds_entity_t w, std::uint32_t n) {
  for (int i = 0; i < 1000; ++i) {
    dds_publication_matched_status_t st{};
    dds_get_publication_matched_status(w, &st);
    if (st.current_count >= n) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

palp_dds_Encoded encoded(const char* rig, std::uint32_t index, std::vector<std::uint8_t>& bytes) {
  palp_dds_Encoded e{};
  e.rig = const_cast<char*>(rig);  // the key: an unbounded string (palp_types.idl)
  e.index = index;
  e.count = 1;
  e.version = 7;
  e.payload._length = e.payload._maximum = static_cast<std::uint32_t>(bytes.size());
  e.payload._buffer = bytes.data();
  return e;
}

class DdsSubscriber : public ::testing::Test {
 protected:
  void SetUp() override { palp::testing::use_dds_loopback(); }
};

TEST_F(DdsSubscriber, EveryTypeRoundTrips) {
  const std::uint32_t domain = unique_dds_domain();
  SubscriberOptions o;
  o.domain = domain;
  o.rig = "rig_a";
  o.ros = true;
  o.volume = true;
  o.contacts = true;
  RigSubscriber sub(o);
  Entity pub = make_participant(domain);
  const dds_entity_t wf = writer(pub.get(), &palp_dds_HapticFrame_desc,
                                 topic_name("rig_a", kFramesContacts), QosKind::Stream, 1);
  const dds_entity_t wp = writer(pub.get(), &geometry_msgs_msg_dds__PoseStamped__desc,
                                 topic_name("rig_a", kToolPose), QosKind::Stream, 1);
  const dds_entity_t ww = writer(pub.get(), &geometry_msgs_msg_dds__WrenchStamped__desc,
                                 topic_name("rig_a", kWrench), QosKind::Stream, 1);
  const dds_entity_t ws =
      writer(pub.get(), &palp_dds_Encoded_desc, topic_name("rig_a", kScene), QosKind::Latched, 1);
  const dds_entity_t wv =
      writer(pub.get(), &palp_dds_Encoded_desc, topic_name("rig_a", kVolume), QosKind::Latched, 1);
  for (const dds_entity_t w : {wf, wp, ww, ws, wv}) ASSERT_TRUE(matched(w, 1));

  palp_dds_HapticFrame f{};
  std::snprintf(f.rig, sizeof f.rig, "rig_a");
  f.frame_index = 3, f.seq = 41, f.server_time_ns = 123456789;
  f.stamp = to_time(1'000'000'000'000'000'001);
  f.position = {1.5, -2.25, 3.0};
  f.orientation = {1, 0, 0, 0};
  f.force = {0.5, 0.25, -4.0};
  f.u = {0, 0, 1.75};
  f.n_contact = 2, f.contact_points = 7, f.device_state = 1, f.fault = 8;
  palp_dds_Contact contacts[2] = {};
  contacts[0].x = {1, 2, 3}, contacts[0].in_contact = true;
  contacts[1].f = {0, 0, -2};
  f.contacts._length = f.contacts._maximum = 2;
  f.contacts._buffer = contacts;
  ASSERT_EQ(dds_write(wf, &f), DDS_RETCODE_OK);
  geometry_msgs_msg_dds__PoseStamped_ pose{};
  char frame_id[] = "palp_scene";
  pose.header.frame_id = frame_id;
  pose.header.stamp = {5, 6};
  pose.pose.position = {0.001, 0.002, 0.003};
  pose.pose.orientation = {0, 0, 0, 1};
  ASSERT_EQ(dds_write(wp, &pose), DDS_RETCODE_OK);
  geometry_msgs_msg_dds__WrenchStamped_ wrench{};
  wrench.header.frame_id = frame_id;
  wrench.wrench.force = {1, 2, 3};
  wrench.wrench.torque = {0.1, 0.2, 0.3};
  ASSERT_EQ(dds_write(ww, &wrench), DDS_RETCODE_OK);
  std::vector<std::uint8_t> bytes = {1, 2, 3, 250};
  palp_dds_Encoded scene = encoded("rig_a", 0, bytes);
  ASSERT_EQ(dds_write(ws, &scene), DDS_RETCODE_OK);
  palp_dds_Encoded chunk = encoded("rig_a", 5, bytes);
  ASSERT_EQ(dds_write(wv, &chunk), DDS_RETCODE_OK);

  int frames = 0, poses = 0, wrenches = 0, scenes = 0, volumes = 0;
  Handlers h;
  h.frame = [&](const palp_dds_HapticFrame& s, std::int64_t) {
    ++frames;
    EXPECT_STREQ(s.rig, "rig_a");
    EXPECT_EQ(s.frame_index, 3u);
    EXPECT_EQ(s.seq, 41u);
    EXPECT_EQ(s.server_time_ns, 123456789);
    EXPECT_EQ(from_time(s.stamp), 1'000'000'000'000'000'001);
    EXPECT_EQ(s.position.y, -2.25);
    EXPECT_EQ(s.force.z, -4.0);
    EXPECT_EQ(s.u.z, 1.75);
    EXPECT_EQ(s.n_contact, 2u);
    EXPECT_EQ(s.contact_points, 7u);
    EXPECT_EQ(s.fault, 8u);
    ASSERT_EQ(s.contacts._length, 2u);
    EXPECT_EQ(s.contacts._buffer[0].x.z, 3.0);
    EXPECT_TRUE(s.contacts._buffer[0].in_contact);
    EXPECT_EQ(s.contacts._buffer[1].f.z, -2.0);
  };
  h.pose = [&](const geometry_msgs_msg_dds__PoseStamped_& s, std::int64_t) {
    ++poses;
    EXPECT_STREQ(s.header.frame_id, "palp_scene");
    EXPECT_EQ(s.header.stamp.sec, 5);
    EXPECT_EQ(s.header.stamp.nanosec, 6u);
    EXPECT_EQ(s.pose.position.z, 0.003);
    EXPECT_EQ(s.pose.orientation.w, 1.0);
  };
  h.wrench = [&](const geometry_msgs_msg_dds__WrenchStamped_& s, std::int64_t) {
    ++wrenches;
    EXPECT_EQ(s.wrench.force.y, 2.0);
    EXPECT_EQ(s.wrench.torque.z, 0.3);
  };
  h.encoded = [&](const char* leaf, const palp_dds_Encoded& s) {
    ASSERT_EQ(s.payload._length, 4u);
    EXPECT_EQ(s.payload._buffer[3], 250);
    EXPECT_EQ(s.version, 7u);
    if (std::strcmp(leaf, kScene) == 0) {
      ++scenes;
      EXPECT_EQ(s.index, 0u);
    }
    if (std::strcmp(leaf, kVolume) == 0) {
      ++volumes;
      EXPECT_EQ(s.index, 5u);
    }
  };
  for (int i = 0; i < 100 && frames + poses + wrenches + scenes + volumes < 5; ++i)
    if (sub.wait(0.1)) sub.take(h);
  EXPECT_EQ(frames, 1);
  EXPECT_EQ(poses, 1);
  EXPECT_EQ(wrenches, 1);
  EXPECT_EQ(scenes, 1);
  EXPECT_EQ(volumes, 1);
  EXPECT_EQ(sub.frame_writers(), 1u);
}

TEST_F(DdsSubscriber, LateJoinerGetsTheSceneNotOldFrames) {
  const std::uint32_t domain = unique_dds_domain();
  Entity pub = make_participant(domain);
  const dds_entity_t ws =
      writer(pub.get(), &palp_dds_Encoded_desc, topic_name("late", kScene), QosKind::Latched, 1);
  const dds_entity_t wf = writer(pub.get(), &palp_dds_HapticFrame_desc, topic_name("late", kFrames),
                                 QosKind::Stream, 1);
  std::vector<std::uint8_t> first = {1}, second = {2};
  palp_dds_Encoded s1 = encoded("late", 0, first), s2 = encoded("late", 0, second);
  ASSERT_EQ(dds_write(ws, &s1), DDS_RETCODE_OK);
  ASSERT_EQ(dds_write(ws, &s2), DDS_RETCODE_OK);  // keep-last(1): only this one is kept
  palp_dds_HapticFrame f{};
  std::snprintf(f.rig, sizeof f.rig, "late");
  ASSERT_EQ(dds_write(wf, &f), DDS_RETCODE_OK);  // volatile: nobody gets this later

  SubscriberOptions o;
  o.domain = domain;
  o.rig = "late";
  RigSubscriber sub(o);
  std::vector<std::uint8_t> got;
  int frames = 0;
  Handlers h;
  h.encoded = [&](const char*, const palp_dds_Encoded& s) { got.push_back(s.payload._buffer[0]); };
  h.frame = [&](const palp_dds_HapticFrame&, std::int64_t) { ++frames; };
  for (int i = 0; i < 100 && got.empty(); ++i)
    if (sub.wait(0.1)) sub.take(h);
  for (int i = 0; i < 3; ++i)
    if (sub.wait(0.1)) sub.take(h);
  EXPECT_EQ(got, std::vector<std::uint8_t>{2});
  EXPECT_EQ(frames, 0);
}

TEST_F(DdsSubscriber, RigsAreSeparateAndListed) {
  const std::uint32_t domain = unique_dds_domain();
  Entity pub = make_participant(domain);
  const dds_entity_t wa = writer(pub.get(), &palp_dds_HapticFrame_desc,
                                 topic_name("rig_a", kFrames), QosKind::Stream, 1);
  const dds_entity_t wb = writer(pub.get(), &palp_dds_HapticFrame_desc,
                                 topic_name("rig_b", kFrames), QosKind::Stream, 1);
  const dds_entity_t wr =
      writer(pub.get(), &palp_dds_RigInfo_desc, kRigsTopic, QosKind::Latched, 1);
  SubscriberOptions o;
  o.domain = domain;
  o.rig = "rig_b";
  RigSubscriber sub(o);
  ASSERT_TRUE(matched(wb, 1));
  dds_publication_matched_status_t st{};
  dds_get_publication_matched_status(wa, &st);
  EXPECT_EQ(st.current_count, 0u);  // rig_a's frames have no reader here
  palp_dds_HapticFrame fa{}, fb{};
  std::snprintf(fa.rig, sizeof fa.rig, "rig_a");
  std::snprintf(fb.rig, sizeof fb.rig, "rig_b");
  fa.seq = 1, fb.seq = 2;
  ASSERT_EQ(dds_write(wa, &fa), DDS_RETCODE_OK);
  ASSERT_EQ(dds_write(wb, &fb), DDS_RETCODE_OK);
  std::vector<std::uint64_t> seqs;
  Handlers h;
  h.frame = [&](const palp_dds_HapticFrame& s, std::int64_t) { seqs.push_back(s.seq); };
  for (int i = 0; i < 100 && seqs.empty(); ++i)
    if (sub.wait(0.1)) sub.take(h);
  if (sub.wait(0.2)) sub.take(h);
  EXPECT_EQ(seqs, std::vector<std::uint64_t>{2});

  char host[] = "bench", scene[] = "phantom:cube", tool[] = "finger:1", device[] = "sim";
  for (const char* name : {"rig_b", "rig_a"}) {
    palp_dds_RigInfo info{};
    info.rig = const_cast<char*>(name);
    info.host = host, info.scene = scene, info.tool = tool, info.device = device;
    info.rate_hz = 1000, info.pid = 42;
    ASSERT_EQ(dds_write(wr, &info), DDS_RETCODE_OK);
  }
  const std::vector<RigSeen> rigs = list_rigs(domain, 1.0);
  ASSERT_EQ(rigs.size(), 2u);
  EXPECT_EQ(rigs[0].rig, "rig_a");
  EXPECT_EQ(rigs[1].rig, "rig_b");
  EXPECT_EQ(rigs[1].scene, "phantom:cube");
  EXPECT_EQ(rigs[1].rate_hz, 1000);
  EXPECT_TRUE(rigs[1].alive);
}

// The keyed types carry `rig` as an unbounded string (palp_types.idl): whoever writes on the
// domain can send any length. A subscriber uses a sample only when its rig is the one it asked
// for, and the rig list only valid rig names (at most kMaxRigBytes), the other strings cut.
TEST_F(DdsSubscriber, ARigThatIsNotOneIsIgnored) {
  const std::uint32_t domain = unique_dds_domain();
  Entity pub = make_participant(domain);
  const dds_entity_t ws =
      writer(pub.get(), &palp_dds_Encoded_desc, topic_name("mine", kScene), QosKind::Latched, 4);
  const dds_entity_t wr =
      writer(pub.get(), &palp_dds_RigInfo_desc, kRigsTopic, QosKind::Latched, 1);
  SubscriberOptions o;
  o.domain = domain;
  o.rig = "mine";
  o.frames = o.stats = false;
  RigSubscriber sub(o);
  ASSERT_TRUE(matched(ws, 1));
  std::string long_rig(100000, 'm');  // "mine" is its prefix: not the same rig all the same
  long_rig.replace(0, 4, "mine");
  std::vector<std::uint8_t> bytes = {9};
  for (const char* rig : {long_rig.c_str(), "other", "mine"}) {
    palp_dds_Encoded e = encoded(rig, 0, bytes);
    ASSERT_EQ(dds_write(ws, &e), DDS_RETCODE_OK);
  }
  std::vector<std::string> got;
  Handlers h;
  h.encoded = [&](const char*, const palp_dds_Encoded& s) {
    got.push_back(std::string(s.rig).substr(0, 16));  // (a failure prints 16 bytes, not 100 kB)
  };
  for (int i = 0; i < 100 && got.empty(); ++i)
    if (sub.wait(0.1)) sub.take(h);
  EXPECT_EQ(got, std::vector<std::string>{"mine"});
  EXPECT_EQ(sub.foreign(), 2u);

  std::string long_host(5000, 'h');
  char scene[] = "phantom:cube", tool[] = "finger:1", device[] = "sim";
  for (const std::string& name : {long_rig, std::string("a-b"), std::string("ok_rig")}) {
    palp_dds_RigInfo info{};
    info.rig = const_cast<char*>(name.c_str());
    info.host = long_host.data(), info.scene = scene, info.tool = tool, info.device = device;
    ASSERT_EQ(dds_write(wr, &info), DDS_RETCODE_OK);
  }
  const std::vector<RigSeen> rigs = list_rigs(domain, 1.0);
  ASSERT_EQ(rigs.size(), 1u);
  EXPECT_EQ(rigs[0].rig, "ok_rig");
  EXPECT_EQ(rigs[0].host.size(), kMaxRigText);
  EXPECT_TRUE(rigs[0].host == long_host.substr(0, kMaxRigText));
}

TEST(DdsRigBound, ReceivedNamesAreReadOnlyUpToTheBound) {
  EXPECT_FALSE(valid_rig(static_cast<const char*>(nullptr)));
  EXPECT_TRUE(valid_rig(std::string(kMaxRigBytes, 'r').c_str()));
  EXPECT_FALSE(valid_rig(std::string(kMaxRigBytes + 1, 'r').c_str()));
  EXPECT_TRUE(same_rig("bed1", "bed1"));
  EXPECT_FALSE(same_rig("bed1", "bed2"));
  EXPECT_FALSE(same_rig(nullptr, "bed1"));
  // Not NUL-terminated within the bound: no byte past kMaxRigBytes + 1 is read (ASan would say).
  std::vector<char> unterminated(kMaxRigBytes + 1, 'r');
  EXPECT_FALSE(valid_rig(unterminated.data()));
}

}  // namespace
}  // namespace palp::dds
