#include "dds_common.hpp"

#include <gtest/gtest.h>

#include "base/errors.hpp"

namespace palp::dds {
namespace {

TEST(DdsCommon, TopicNamesFollowRos2Convention) {
  EXPECT_EQ(topic_name("rig_a", kToolPose), "rt/palp/rig_a/tool_pose");
  EXPECT_EQ(topic_name("rig_a", kWrench), "rt/palp/rig_a/wrench");
  EXPECT_STREQ(kRigsTopic, "rt/palp/rigs");
}

TEST(DdsCommon, RigNames) {
  EXPECT_TRUE(valid_rig("palp"));
  EXPECT_TRUE(valid_rig("Rig_2"));
  EXPECT_FALSE(valid_rig(""));
  EXPECT_FALSE(valid_rig("2rig"));
  EXPECT_FALSE(valid_rig("rig-a"));
  EXPECT_FALSE(valid_rig("a/b"));
  EXPECT_FALSE(valid_rig(std::string(64, 'a')));
  EXPECT_TRUE(valid_rig(std::string(63, 'a')));
  EXPECT_THROW(check_rig("a b"), UsageError);
  EXPECT_TRUE(valid_rig(default_rig()));
}

TEST(DdsCommon, Domains) {
  EXPECT_EQ(parse_domain("0"), 0u);
  EXPECT_EQ(parse_domain("232"), 232u);
  EXPECT_THROW(parse_domain("233"), UsageError);
  EXPECT_THROW(parse_domain("-1"), UsageError);
  EXPECT_THROW(parse_domain("x"), UsageError);
  EXPECT_THROW(parse_domain(""), UsageError);
  EXPECT_THROW(parse_domain("1000"), UsageError);
}

TEST(DdsCommon, Times) {
  const auto t = to_time(1'700'000'000'123'456'789);
  EXPECT_EQ(t.sec, 1'700'000'000);
  EXPECT_EQ(t.nanosec, 123'456'789u);
  EXPECT_EQ(from_time(t), 1'700'000'000'123'456'789);
  const auto n = to_time(-1);
  EXPECT_EQ(n.sec, -1);
  EXPECT_EQ(n.nanosec, 999'999'999u);
  EXPECT_EQ(from_time(n), -1);
}

TEST(DdsCommon, QosOfEachKind) {
  const QosPtr stream = make_qos(QosKind::Stream, 4);
  dds_reliability_kind_t rel{};
  dds_duration_t blocking = 0;
  ASSERT_TRUE(dds_qget_reliability(stream.get(), &rel, &blocking));
  EXPECT_EQ(rel, DDS_RELIABILITY_BEST_EFFORT);
  dds_history_kind_t hist{};
  std::int32_t depth = 0;
  ASSERT_TRUE(dds_qget_history(stream.get(), &hist, &depth));
  EXPECT_EQ(hist, DDS_HISTORY_KEEP_LAST);
  EXPECT_EQ(depth, 4);
  const QosPtr latched = make_qos(QosKind::Latched, 1);
  ASSERT_TRUE(dds_qget_reliability(latched.get(), &rel, &blocking));
  EXPECT_EQ(rel, DDS_RELIABILITY_RELIABLE);
  dds_durability_kind_t dur{};
  ASSERT_TRUE(dds_qget_durability(latched.get(), &dur));
  EXPECT_EQ(dur, DDS_DURABILITY_TRANSIENT_LOCAL);
}

}  // namespace
}  // namespace palp::dds
