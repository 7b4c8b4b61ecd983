// The CT check passes the phantoms and refuses what is not a CT in HU, saying what it saw.
#include "prep/ct_check.hpp"

#include <gtest/gtest.h>

#include "io/phantom.hpp"

namespace palp {
namespace {

CtVolume torso() {
  PhantomOptions o;
  o.dims = Index3{96, 64, 24};
  o.spacing = Vec3{5.0, 5.0, 8.0};
  return make_phantom("torso", o);
}

TEST(CtCheck, PhantomsAreCts) {
  for (const char* name : {"cube", "sphere"})
    EXPECT_TRUE(check_hu(make_phantom(name)).plausible) << name;
  const CtCheck c = check_hu(torso());
  EXPECT_TRUE(c.plausible) << c.finding;
  EXPECT_TRUE(c.finding.empty());
  EXPECT_GT(c.air_fraction, kMinAirFraction);
  EXPECT_GT(c.soft_fraction, kMinSoftFraction);
}

TEST(CtCheck, CtWithoutItsRescaleIsRefused) {
  CtVolume ct = torso();
  for (std::int16_t& v : ct.data) v = static_cast<std::int16_t>(v + 1024);  // stored values
  const CtCheck c = check_hu(ct);
  EXPECT_FALSE(c.plausible);
  EXPECT_EQ(c.air_fraction, 0.0);
  EXPECT_NE(c.finding.find("without its rescale"), std::string::npos) << c.finding;
  const std::string message = not_a_ct_message("x.nii", c);
  EXPECT_NE(message.find("--not-hu-ok"), std::string::npos) << message;
}

TEST(CtCheck, LabelMapIsRefused) {
  CtVolume ct = torso();
  for (std::int16_t& v : ct.data) v = v > 300 ? 2 : v > -500 ? 1 : 0;
  const CtCheck c = check_hu(ct);
  EXPECT_FALSE(c.plausible);
  EXPECT_EQ(c.distinct_values, 3u);
  EXPECT_NE(c.finding.find("label map"), std::string::npos) << c.finding;
}

TEST(CtCheck, IntensitiesWithoutAirAreRefused) {
  CtVolume ct = torso();  // an MR-like volume: 0 outside, a few hundred inside
  for (std::int16_t& v : ct.data) v = static_cast<std::int16_t>(v < -500 ? 3 : 200 + v / 4);
  const CtCheck c = check_hu(ct);
  EXPECT_FALSE(c.plausible);
  EXPECT_NE(c.finding.find("no value is near air"), std::string::npos) << c.finding;
}

TEST(CtCheck, BodyFillingTheGridIsRefused) {
  Grid g;
  g.dims = {10, 10, 10};
  EXPECT_TRUE(check_body_fraction(500, g).empty());
  EXPECT_TRUE(check_body_fraction(950, g).empty());
  const std::string finding = check_body_fraction(1000, g);
  EXPECT_NE(finding.find("fills 100.0% of the grid"), std::string::npos) << finding;
}

}  // namespace
}  // namespace palp
