// The trunk phantom's truth as anatomy::Landmarks (anatomy/trunk_truth.hpp): everything
// io/phantom_trunk.hpp gives, carried over with confidence 1, what the volume cannot show absent
// with its reason.
#include "anatomy/trunk_truth.hpp"

#include <gtest/gtest.h>

namespace palp::anatomy {
namespace {

TEST(TrunkTruth, EveryLandmarkOfThePhantomWithFullConfidence) {
  const Landmarks l = trunk_landmark_truth();
  const TrunkTruth t = trunk_truth();
  EXPECT_EQ(l.scene, "phantom:trunk");
  ASSERT_EQ(l.vertebrae.size(), t.vertebrae.size());
  EXPECT_EQ(l.vertebrae.front().name, "S");
  EXPECT_EQ(l.vertebrae.back().name, "T8");
  for (const Vertebra& v : l.vertebrae) EXPECT_EQ(v.confidence, 1.0);
  ASSERT_EQ(l.ribs.size(), 10u);
  for (const Rib& r : l.ribs) {
    ASSERT_TRUE(r.number);
    EXPECT_GE(*r.number, 8);
    EXPECT_LE(*r.number, 12);
    EXPECT_FALSE(r.points.empty());
  }
  ASSERT_EQ(l.intercostal_spaces.size(), 8u);
  int shown = 0;
  for (const IntercostalSpace& s : l.intercostal_spaces) {
    if (s.skin_point) {
      ++shown;
      EXPECT_EQ(s.confidence, 1.0);
      EXPECT_TRUE(s.normal);
    } else {
      EXPECT_EQ(s.upper_rib, 11);
      EXPECT_FALSE(s.reason.empty());
    }
  }
  EXPECT_EQ(shown, 6);
  ASSERT_EQ(l.iliac_crests.size(), 2u);
  EXPECT_EQ(l.iliac_crests[0].side, Side::right);
  EXPECT_EQ(l.tuffier_line.vertebral_level, "L4/L5");
  ASSERT_TRUE(l.tuffier_line.z_mm);
  EXPECT_DOUBLE_EQ(*l.tuffier_line.z_mm, t.tuffier_z);
  ASSERT_EQ(l.lumbar_interspaces.size(), 5u);
  EXPECT_EQ(l.lumbar_interspaces[2].name, "L3/L4");
  ASSERT_EQ(l.femoral_pulse_points.size(), 2u);
  for (const FemoralPulsePoint& f : l.femoral_pulse_points) {
    EXPECT_EQ(f.source, "artery");
    EXPECT_TRUE(f.skin_point && f.normal);
  }
  EXPECT_EQ(l.femoral_pulse_points[1].side, Side::left);
  EXPECT_FALSE(l.notes.empty());
}

TEST(TrunkTruth, TheSameWorldPointsWhateverTheStorageOrder) {
  PhantomOptions o;
  o.orient = "ASR";
  const Landmarks a = trunk_landmark_truth(o);
  const Landmarks b = trunk_landmark_truth();
  ASSERT_EQ(a.ribs.size(), b.ribs.size());
  for (std::size_t n = 0; n < a.ribs.size(); ++n) EXPECT_EQ(a.ribs[n].points, b.ribs[n].points);
  EXPECT_EQ(a.lumbar_interspaces[3].skin_point, b.lumbar_interspaces[3].skin_point);
}

}  // namespace
}  // namespace palp::anatomy
