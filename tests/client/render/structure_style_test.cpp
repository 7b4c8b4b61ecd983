// The structures' styles (client/render/structure_style.cpp) without a display: the artery red and
// beating (dark and faint at diastole, bright and dense at systole), the vessels blue, every organ
// a colour of its own that is neither, and the legend naming each structure in label order.
#include "render/structure_style.hpp"

#include <gtest/gtest.h>

#include <set>

namespace palp::view {
namespace {

std::vector<SceneDescription::Structure> scene_structures() {
  return {{1, "vessel", "vessel"},
          {2, "artery", "artery"},
          {3, "kidney_left", "organ"},
          {4, "liver", "organ"},
          {5, "thyroid", "organ"},
          {6, "prostate", "organ"}};
}

bool reddish(const std::array<double, 3>& c) { return c[0] > c[1] + 0.3 && c[0] > c[2] + 0.3; }
bool bluish(const std::array<double, 3>& c) { return c[2] > c[0] + 0.3 && c[2] > c[1] + 0.3; }

TEST(StructureStyle, ArteryRedVesselsBlueOrgansTheirOwn) {
  const auto styles = structure_styles(scene_structures());
  ASSERT_EQ(styles.size(), 6u);
  EXPECT_EQ(styles[1].label, 2);
  EXPECT_TRUE(reddish(styles[1].rgb));
  EXPECT_TRUE(bluish(styles[0].rgb));
  std::set<std::array<double, 3>> colours;
  for (const StructureStyle& s : styles) colours.insert(s.rgb);
  EXPECT_EQ(colours.size(), 6u);  // six structures, six colours
  for (std::size_t i = 2; i < styles.size(); ++i) {
    EXPECT_FALSE(reddish(styles[i].rgb)) << styles[i].name;
    EXPECT_FALSE(bluish(styles[i].rgb)) << styles[i].name;
    EXPECT_LT(styles[i].opacity, styles[0].opacity) << "organs fainter than the vessels";
  }
}

TEST(StructureStyle, TheArteryBeatsWithTheWave) {
  const auto styles = structure_styles(scene_structures());
  const StructureStyle diastole = pulsed(styles[1], 0.0), systole = pulsed(styles[1], 1.0);
  EXPECT_GT(systole.rgb[0], diastole.rgb[0] + 0.4);
  EXPECT_GT(systole.opacity, 3 * diastole.opacity);
  const StructureStyle half = pulsed(styles[1], 0.5);
  EXPECT_GT(half.rgb[0], diastole.rgb[0]);
  EXPECT_LT(half.rgb[0], systole.rgb[0]);
  EXPECT_EQ(pulsed(styles[1], 7.0).rgb, systole.rgb);  // clamped
  EXPECT_EQ(pulsed(styles[1], -1.0).rgb, diastole.rgb);
  EXPECT_EQ(pulsed(styles[0], 0.0).rgb, styles[0].rgb);  // the vessels do not beat
}

TEST(StructureStyle, TheLegendListsTheStructures) {
  const auto styles = structure_styles(scene_structures());
  EXPECT_EQ(legend_lines(styles, 72.0),
            (std::vector<std::string>{"vessel", "artery  (pulse 72 bpm)", "kidney_left", "liver",
                                      "thyroid", "prostate"}));
  EXPECT_EQ(legend_lines(styles, 0.0)[1], "artery  (no pulse)");
  EXPECT_EQ(legend_lines(styles, std::nullopt)[1], "artery");
  EXPECT_TRUE(legend_lines({}, 72.0).empty());
}

}  // namespace
}  // namespace palp::view
