// palp tune's core (common/tune/tuner.cpp): the decision on hand-made figures (a fast candidate
// with wrong forces and an accurate one too slow for the rate are rejected, each with its reason;
// near-equal ticks are decided by memory, so noise does not flip the choice), the footprints, and
// an end-to-end run on a tiny ball scene (the reference's error is exactly zero, fewer points
// than the reference on a curved skin err, the accuracy part repeats exactly).
#include "tune/tuner.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "base/errors.hpp"
#include "prep/maps/distance_transform.hpp"

namespace palp::tune {
namespace {

Judged candidate(const char* tool, double p50, double p99, double rms, double max, double step,
                 std::size_t bytes) {
  Judged j;
  j.candidate.tool = tool;
  j.measured.tick_p50_us = p50;
  j.measured.tick_p99_us = p99;
  j.measured.rms_error_n = rms;
  j.measured.max_error_n = max;
  j.measured.step_excess_n = step;
  j.measured.map_bytes = bytes;
  return j;
}

TEST(Tuner, RejectsFastButWrongAndAccurateButSlow) {
  // 1 kHz: period 1000 us, budget 250 us. Tolerance 0.1 N RMS, 0.3 N largest.
  std::vector<Judged> r = {
      candidate("reference", 4.0, 5.0, 0.0, 0.0, 0.0, 300),
      candidate("fast but wrong", 0.5, 0.6, 0.4, 0.9, 0.0, 100),
      candidate("fast, one large error", 0.6, 0.7, 0.05, 0.5, 0.0, 100),
      candidate("fast, steps", 0.7, 0.8, 0.05, 0.1, 0.2, 100),
      candidate("accurate but slow", 1.0, 400.0, 0.0, 0.0, 0.0, 100),
      candidate("good", 2.0, 3.0, 0.05, 0.1, 0.01, 200),
      candidate("good, within 10 %, less memory", 2.15, 3.0, 0.08, 0.1, 0.01, 150),
      candidate("good, 15 % slower, least memory", 2.3, 3.0, 0.01, 0.02, 0.0, 50),
  };
  Tolerance tol;
  const std::size_t chosen = judge(r, tol, 0.1, 1000.0);
  EXPECT_EQ(chosen, 6u);
  EXPECT_TRUE(r[6].chosen);
  EXPECT_TRUE(r[0].reference);
  EXPECT_TRUE(r[0].accepted);
  EXPECT_EQ(r[1].reason, "force error: RMS 0.400 N > 0.100 N");
  EXPECT_EQ(r[2].reason, "force error: largest 0.500 N > 0.300 N");
  EXPECT_EQ(r[3].reason, "per-tick step 0.200 N above the reference's (> 0.100 N)");
  EXPECT_EQ(r[4].reason, "too slow: tick p99 400.00 us > 250.00 us");
  for (std::size_t i : {1u, 2u, 3u, 4u}) EXPECT_FALSE(r[i].accepted) << i;
  for (std::size_t i : {5u, 6u, 7u}) EXPECT_TRUE(r[i].accepted) << i;
  // Equal memory inside the tie: the smaller error.
  r[6].measured.map_bytes = 200;
  EXPECT_EQ(judge(r, tol, 0.1, 1000.0), 5u);
}

TEST(Tuner, WhenEvenTheReferenceIsTooSlowItIsReturnedNotAccepted) {
  std::vector<Judged> r = {candidate("reference", 40.0, 60.0, 0, 0, 0, 1),
                           candidate("wrong", 1.0, 2.0, 1.0, 1.0, 0, 1)};
  EXPECT_EQ(judge(r, Tolerance{}, 0.1, 100.0), 0u);  // 10 kHz: budget 25 us
  EXPECT_FALSE(r[0].accepted);
  EXPECT_TRUE(r[0].chosen);
  std::vector<Judged> none;
  EXPECT_THROW(judge(none, Tolerance{}, 0.1, 1000.0), UsageError);
}

TEST(Tuner, ToleranceIsTheLargerOfTheFloorAndTheShare) {
  Tolerance tol;
  EXPECT_DOUBLE_EQ(tolerance_for(tol, 0.5), 0.05);
  EXPECT_DOUBLE_EQ(tolerance_for(tol, 4.0), 0.28);
}

TEST(Tuner, FootprintsAreTheToolAndSparserOnes) {
  EXPECT_EQ(footprint_tools(parse_tool("finger:37")),
            (std::vector<std::string>{"finger:37", "finger:19", "finger:7", "finger:1"}));
  EXPECT_EQ(footprint_tools(parse_tool("finger:7")),
            (std::vector<std::string>{"finger:7", "finger:1"}));
  EXPECT_EQ(footprint_tools(parse_tool("twofinger:19")),
            (std::vector<std::string>{"twofinger:19", "twofinger:7", "twofinger:1"}));
  EXPECT_EQ(
      footprint_tools(parse_tool("probe:9x3")),
      (std::vector<std::string>{"probe:9x3", "probe:5x2", "probe:3x1", "probe:2x1", "probe:1x1"}));
}

// A skin ball (radius 25 mm) around a bone ball (radius 12 mm), exact signed distances at 1 mm.
DistanceMap ball(double radius) {
  Grid g;
  g.dims = {70, 70, 70};
  DistanceMap m(g, 0.0f);
  for (std::int64_t k = 0; k < 70; ++k)
    for (std::int64_t j = 0; j < 70; ++j)
      for (std::int64_t i = 0; i < 70; ++i) {
        const double r =
            std::sqrt((i - 35.0) * (i - 35.0) + (j - 35.0) * (j - 35.0) + (k - 35.0) * (k - 35.0));
        m.at(i, j, k) = static_cast<float>(radius - r);
      }
  return m;
}

TEST(Tuner, EndToEndOnABall) {
  palp::tune::Setup setup;  // (qualified: gtest reserves Setup)
  setup.tool = "finger:7";
  setup.rate_hz = 1000.0;
  setup.params = palp_params(ToolKind::Finger);
  setup.repeats = 1;
  const DistanceMap skin = ball(25.0), bone = ball(12.0);
  const Outcome a = tune(skin, bone, setup);
  ASSERT_EQ(a.results.size(), 2u * 9u);  // finger:7 and finger:1, 3 schemes x 3 storages
  EXPECT_GT(a.ticks, 1000u);
  EXPECT_FALSE(a.trajectories.empty());
  EXPECT_EQ(a.results[0].candidate.tool, "finger:7");
  EXPECT_EQ(a.results[0].candidate.sampler.gradient, GradientScheme::PrecomputedField);
  EXPECT_EQ(a.results[0].candidate.sampler.storage, Storage::Float32);
  EXPECT_EQ(a.results[0].measured.rms_error_n, 0.0);
  EXPECT_EQ(a.results[0].measured.max_error_n, 0.0);
  EXPECT_GT(a.reference_rms_force_n, 0.1);
  // One point on a 25 mm ball is not the 2.5 mm ring of seven.
  EXPECT_GT(a.results[9].measured.rms_error_n, 0.0);
  ASSERT_LT(a.chosen, a.results.size());
  EXPECT_TRUE(a.results[a.chosen].accepted);  // 1 kHz leaves this tiny scene plenty of time
  const Outcome b = tune(skin, bone, setup);
  for (std::size_t i = 0; i < a.results.size(); ++i) {
    EXPECT_EQ(a.results[i].measured.rms_error_n, b.results[i].measured.rms_error_n) << i;
    EXPECT_EQ(a.results[i].measured.map_bytes, b.results[i].measured.map_bytes) << i;
  }
}

// A budget smaller than building the first maps stops the tuning with OverBudget (palpd --tune
// then runs the defaults); none (0) lets it finish.
TEST(Tuner, ABudgetTooSmallStopsWithOverBudget) {
  palp::tune::Setup setup;
  setup.tool = "finger:1";
  setup.rate_hz = 1000.0;
  setup.params = palp_params(ToolKind::Finger);
  setup.repeats = 1;
  setup.budget_s = 1e-9;
  const DistanceMap skin = ball(25.0), bone = ball(12.0);
  EXPECT_THROW(tune(skin, bone, setup), OverBudget);
  try {
    tune(skin, bone, setup);
  } catch (const OverBudget& e) {
    EXPECT_NE(std::string(e.what()).find("over the time budget"), std::string::npos) << e.what();
  }
  setup.budget_s = 0.0;
  EXPECT_EQ(tune(skin, bone, setup).results.size(), 9u);
}

}  // namespace
}  // namespace palp::tune
