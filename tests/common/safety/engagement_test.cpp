// Force engagement: held off while the commanded force is large, then a linear ramp; exact gains.
#include "safety/engagement.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "base/errors.hpp"

namespace palp {
namespace {

TEST(Engagement, WaitsForASmallForceThenRampsLinearly) {
  EngageParams p;
  p.threshold_N = 0.2;
  p.ramp_s = 0.004;  // four 1 ms ticks
  Engagement e;
  EXPECT_EQ(e.gain, 0.0);
  e = engage(e, 5.0, 0.001, p);  // pressing: held off
  EXPECT_TRUE(e.waiting);
  EXPECT_EQ(e.gain, 0.0);
  e = engage(e, 0.2, 0.001, p);  // not below the threshold yet
  EXPECT_TRUE(e.waiting);
  e = engage(e, 0.1, 0.001, p);  // small: the ramp starts from 0
  EXPECT_FALSE(e.waiting);
  EXPECT_EQ(e.gain, 0.0);
  const double expected[] = {0.25, 0.5, 0.75, 1.0, 1.0};
  for (double g : expected) {
    e = engage(e, 7.0, 0.001, p);  // the force may grow again during the ramp: it is scaled
    EXPECT_NEAR(e.gain, g, 1e-12);
  }
  EXPECT_TRUE(e.engaged());
}

TEST(Engagement, NonFiniteForceNeverEngagesAndLongGapsDoNotJump) {
  EngageParams p;
  p.ramp_s = 1.0;
  Engagement e = engage(Engagement{}, std::nan(""), 0.001, p);
  EXPECT_TRUE(e.waiting);
  e = engage(e, 0.0, 0.001, p);
  e = engage(e, 0.0, 5.0, p);  // a 5 s pause in ticking counts as 10 ms
  EXPECT_NEAR(e.gain, 0.01, 1e-12);
}

TEST(Engagement, BadParametersAreRefused) {
  EXPECT_NO_THROW(validate(EngageParams{}));
  EXPECT_THROW(validate(EngageParams{0.0, 1.0}), UsageError);
  EXPECT_THROW(validate(EngageParams{0.2, -1.0}), UsageError);
  EXPECT_THROW(validate(EngageParams{0.2, 11.0}), UsageError);
}

}  // namespace
}  // namespace palp
