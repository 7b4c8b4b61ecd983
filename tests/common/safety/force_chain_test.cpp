// The force chain from model to device: engagement scales the limiter's output without slowing
// it (the limiter follows its own output), the step bound holds on what is written, and the
// passivity controller never pulls.
#include "safety/force_chain.hpp"

#include <gtest/gtest.h>

namespace palp {
namespace {

// A profile whose stiffness limit never binds: only the clamp and the rate limit act.
DeviceProfile stiff_profile() {
  DeviceProfile p = device_profile("falcon");  // 8 N, 1600 N/s: 1.6 N a tick at 1 kHz
  p.max_stiffness_N_per_mm = 1e9;
  p.settle_rate_N_per_s = 1e9;  // at rest too
  return p;
}

// The chain with the stiffness limiter in place of the virtual coupling.
ForceChainConfig limiter() {
  ForceChainConfig config;
  config.coupling = false;
  return config;
}

TEST(ForceChain, EngagementScalesTheLimitedForceLinearly) {
  const DeviceProfile p = stiff_profile();
  ForceChainConfig config = limiter();
  config.engage = EngageParams{0.2, 0.005};  // five ticks
  ForceChainState s;
  const Vec3d at{0, 0, 0};
  // Out of contact: engages (the ramp starts from 0).
  EXPECT_EQ(run_force_chain(s, config, p, {}, {}, 0.0, at, 0.001).force, Vec3d{});
  EXPECT_FALSE(s.engagement.waiting);
  // Then a constant 2 N: the limiter reaches 1.6 then 2 N, the gain 0.2, 0.4, ... 1.
  const double expected[] = {0.2 * 1.6, 0.4 * 2.0, 0.6 * 2.0, 0.8 * 2.0, 2.0, 2.0};
  for (double e : expected)
    EXPECT_NEAR(run_force_chain(s, config, p, {0, 0, 2}, {}, 0.0, at, 0.001).force.z, e, 1e-12);
  EXPECT_TRUE(s.engagement.engaged());
}

TEST(ForceChain, StepBoundHoldsOnWhatIsWritten) {
  const DeviceProfile p = stiff_profile();
  ForceChainState s;
  double previous = 0.0;
  for (int n = 0; n < 10; ++n) {
    const double f = run_force_chain(s, limiter(), p, {0, 0, 100}, {}, 0.0, {}, 0.001).force.z;
    EXPECT_LE(f - previous, 1.6 + 1e-12);
    previous = f;
  }
  EXPECT_EQ(previous, 8.0);  // clamped
  reset_force_chain(s);
  EXPECT_NEAR(run_force_chain(s, limiter(), p, {0, 0, 100}, {}, 0.0, {}, 0.001).force.z, 1.6,
              1e-12);
}

TEST(ForceChain, ThePassivityControllerLetsGoRatherThanPull) {
  DeviceProfile p = stiff_profile();
  p.damping_N_s_per_mm = 10.0;  // a damper strong enough to reverse 1 N
  ForceChainConfig config = limiter();
  config.passivity = true;
  ForceChainState s;
  s.limited_prev = s.written_prev = {0, 0, 1};
  s.passivity.energy_mJ = -5.0;  // a deficit to dissipate
  s.have_prev = true;
  s.position_prev = {0, 0, 0};
  s.velocity = {0, 0, 100};  // moving out fast, along the force
  const ForceChainOutput out =
      run_force_chain(s, config, p, {0, 0, 1}, {}, 0.0, {0, 0, 0.1}, 0.001);
  EXPECT_GT(out.damping_N_s_per_mm, 0.0);
  EXPECT_NE(out.status & kSafetyPassivity, 0u);
  EXPECT_GE(out.force.z, 0.0);  // never below zero: it let go
}

}  // namespace
}  // namespace palp
