// The landmarks' labels in palpview (client/render/landmark_layer.cpp), without a display: one
// label per name, a vertebra's at its spinous tip (the point the fingers find) and not twice, a
// rib's at its last point (the end away from the head), an interspace's to the left of its point,
// everything else at its middle point to the right; and when the layer may draw at all.
#include "render/landmark_layer.hpp"

#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <string>

namespace palp::view {
namespace {

// Named as palpd's LandmarkSet names them (server/net/task_session.cpp, wire_landmarks).
std::vector<LandmarkPoint> spine_and_ribs() {
  return {{"ICS R9/10", "intercostal", {-160, -160, 390}},
          {"rib R9", "rib", {-142, -139, 427}},
          {"rib R9", "rib", {-135, -170, 400}},
          {"rib R9", "rib", {-128, -195, 378}},
          {"L3", "vertebra", {5, -141, 316}},
          {"L3 spinous", "spinous", {-1, -73, 304}},
          {"L5", "vertebra", {1, -131, 242}},
          {"X spinous", "spinous", {0, -60, 200}},
          {"L3/L4", "interspace", {0, -45, 294}},
          {"iliac crest R", "iliac", {-98, -119, 276}}};
}

TEST(LandmarkLabels, OnePerNameWhereTheFingersFindIt) {
  const auto labels = landmark_labels(spine_and_ribs());
  std::map<std::string, LandmarkLabel> by_text;
  for (const LandmarkLabel& l : labels) EXPECT_TRUE(by_text.emplace(l.text, l).second) << l.text;
  ASSERT_EQ(labels.size(), 7u);  // "L3 spinous" is L3's label; "X spinous" alone says "X"
  EXPECT_EQ(by_text.count("L3 spinous"), 0u);
  EXPECT_EQ(by_text.at("L3").at.z, 304);  // at the tip, not the body centre (316)
  EXPECT_EQ(by_text.at("L3").at.y, -73);
  EXPECT_EQ(by_text.at("L5").at.z, 242);  // no tip: the body centre
  EXPECT_EQ(by_text.at("X").at.z, 200);
  EXPECT_EQ(by_text.at("rib R9").at.y, -195);  // the rib's free end
  EXPECT_TRUE(by_text.at("L3/L4").left);
  EXPECT_FALSE(by_text.at("L3").left);
  EXPECT_FALSE(by_text.at("ICS R9/10").left);  // a space beside the ribs, not the midline
  EXPECT_EQ(by_text.at("iliac crest R").at.x, -98);
}

TEST(LandmarkLabels, AtMostTheCap) {
  std::vector<LandmarkPoint> many;
  for (std::size_t i = 0; i < kMaxLandmarkLabels + 20; ++i)
    many.push_back({std::to_string(i), "rib", {0, 0, static_cast<double>(i)}});
  EXPECT_EQ(landmark_labels(many).size(), kMaxLandmarkLabels);
  EXPECT_TRUE(landmark_labels({}).empty());
}

TEST(LandmarkLabels, ShownOnlyWhenWantedReceivedAndAllowed) {
  LatestState state;
  EXPECT_FALSE(landmarks_shown(state, true));  // none received
  state.landmarks = std::make_shared<const std::vector<LandmarkPoint>>(spine_and_ribs());
  EXPECT_TRUE(landmarks_shown(state, true));  // a palpd without tasks: allowed
  EXPECT_FALSE(landmarks_shown(state, false));
  state.task = TaskInfo{};
  state.task->show_landmarks = false;  // the trainee's controller while a task runs
  EXPECT_FALSE(landmarks_shown(state, true));
  state.task->show_landmarks = true;  // an observer
  EXPECT_TRUE(landmarks_shown(state, true));
}

}  // namespace
}  // namespace palp::view
