// Tests for control_target.hpp: each Command reaches its ControlTarget call, refusals and
// exceptions come back as the reason, and only accepted tool and parameter changes ask for a
// new SceneInfo.
#include "net/control_target.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

namespace palp::net {
namespace {

class FakeTarget final : public ControlTarget {
 public:
  std::string set_tool(const std::string& tool) override {
    calls += "tool:" + tool + ";";
    return tool == "bad" ? "unknown tool" : "";
  }
  std::string set_parameter(const std::string& name, double) override {
    if (name == "boom") throw std::runtime_error("k must be in [0, 10]");
    calls += "param:" + name + ";";
    return "";
  }
  std::string set_paused(bool paused) override {
    calls += paused ? "pause;" : "resume;";
    return "";
  }
  std::string recentre() override { return "no device"; }
  std::string start_recording(const std::string& name, const std::string& by) override {
    calls += "record:" + name + " by " + by + ";";
    return "";
  }
  std::string stop_recording() override { return ""; }
  bool recording() const override { return false; }
  std::uint64_t record_lost() const override { return 0; }
  bool set_device_pose(const Pose&, std::int64_t) override { return false; }
  std::string calls;
};

TEST(ControlTarget, CommandsReachTheirCallsAndOnlyAcceptedChangesTouchTheScene) {
  FakeTarget target;
  bool scene = true;
  v1::Command c;
  c.mutable_set_tool()->set_tool("ball:5");
  EXPECT_EQ(apply_command(&target, c, "client 1", scene), "");
  EXPECT_TRUE(scene);
  c.mutable_set_tool()->set_tool("bad");
  EXPECT_EQ(apply_command(&target, c, "client 1", scene), "unknown tool");
  EXPECT_FALSE(scene);
  c.mutable_set_parameter()->set_name("k");
  EXPECT_EQ(apply_command(&target, c, "client 1", scene), "");
  EXPECT_TRUE(scene);
  c.mutable_set_parameter()->set_name("boom");
  EXPECT_EQ(apply_command(&target, c, "client 1", scene), "k must be in [0, 10]");
  EXPECT_FALSE(scene);
  c.mutable_pause()->set_paused(true);
  EXPECT_EQ(apply_command(&target, c, "client 1", scene), "");
  EXPECT_FALSE(scene);
  c.mutable_recentre();
  EXPECT_EQ(apply_command(&target, c, "client 1", scene), "no device");
  c.mutable_start_recording()->set_name("run1");
  EXPECT_EQ(apply_command(&target, c, "client 1", scene), "");
  EXPECT_EQ(target.calls, "tool:ball:5;tool:bad;param:k;pause;record:run1 by client 1;");
  EXPECT_EQ(apply_command(&target, v1::Command{}, "client 1", scene), "empty command");
  EXPECT_EQ(apply_command(nullptr, c, "client 1", scene), "this server takes no commands");
  EXPECT_FALSE(scene);
}

}  // namespace
}  // namespace palp::net
