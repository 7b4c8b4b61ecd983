// The force chain from model to device: engagement scales the limiter's output without slowing
// it (the limiter follows its own output), the step bound holds on what is written, the
// passivity controller never pulls, and the passivity observer sums the force actually written
// against the travel while it was held (expected energies summed by hand in each test).
#include "safety/force_chain.hpp"

#include <gtest/gtest.h>

namespace palp {
namespace {

// A profile whose stiffness limit never binds: only the clamp and the rate limit act.
DeviceProfile stiff_profile() {
  DeviceProfile p = device_profile("falcon");  // 8 N, 1600 N/s: 1.6 N a tick at 1 kHz
  p.transport_delay_s = 0.0;  // the force written at a tick is applied over the next
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

TEST(ForceChain, TheObserverSeesTheForceAfterTheStepBound) {
  // The coupling renders a constant 100 N model force (no stiffness: the tool's implicit step
  // passes it on exactly), clamped to 8 N; the step bound then writes 1.6, 3.2, 4.8, 6.4, 8 N.
  // The device moves 0.1 mm out, along the force, each tick. Observer only (no damping).
  DeviceProfile p = device_profile("falcon");
  p.damping_N_s_per_mm = 0.0;
  p.transport_delay_s = 0.0;
  ForceChainConfig config;
  config.passivity = true;
  ForceChainState s;
  const double written[] = {1.6, 3.2, 4.8, 6.4, 8.0, 8.0};
  double expected = 0.0;
  for (int n = 0; n < 6; ++n) {
    const ForceChainOutput out =
        run_force_chain(s, config, p, {0, 0, 100}, {}, 0.0, {0, 0, 0.1 * n}, 0.001);
    EXPECT_NEAR(out.force.z, written[n], 1e-9) << n;
    if (n > 0) expected -= written[n - 1] * 0.1;  // returned: 0.16, 0.32, ... mJ
    EXPECT_NEAR(s.passivity.energy_mJ, expected, 1e-9) << n;
  }
  EXPECT_NEAR(expected, -2.4, 1e-12);
}

TEST(ForceChain, LettingGoIsNotCreditedAsDissipation) {
  // A deficit of 5 mJ, the device moving out at 100 mm/s along 1 N: the damper would reverse
  // the force, so the chain writes 0. The observer sees 1 N over the first 0.1 mm (-0.1 mJ), then
  // nothing: the deficit stays, as no energy went back into the environment.
  DeviceProfile p = stiff_profile();
  p.damping_N_s_per_mm = 10.0;
  ForceChainConfig config = limiter();
  config.passivity = true;
  ForceChainState s;
  s.limited_prev = s.written_prev = {0, 0, 1};
  s.passivity.energy_mJ = -5.0;
  s.have_prev = true;
  s.position_prev = {0, 0, 0};
  s.velocity = {0, 0, 100};
  for (int n = 1; n <= 3; ++n) {
    const ForceChainOutput out =
        run_force_chain(s, config, p, {0, 0, 1}, {}, 0.0, {0, 0, 0.1 * n}, 0.001);
    EXPECT_EQ(out.force, Vec3d{}) << n;
    EXPECT_NEAR(s.passivity.energy_mJ, -5.1, 1e-12) << n;
  }
}

TEST(ForceChain, ATickWithoutForceDoesNotResetTheObserver) {
  // 1 N pressed in 0.1 mm twice (+0.1 mJ each), a tick with no model force (0 written), then
  // 1 N again while the device comes back out 0.1 mm a tick.
  DeviceProfile p = stiff_profile();
  p.damping_N_s_per_mm = 0.0;
  ForceChainConfig config = limiter();
  config.passivity = true;
  ForceChainState s;
  const double z[] = {0.0, -0.1, -0.2, -0.1, 0.0};
  const double model[] = {1, 1, 0, 1, 1};
  const double energy[] = {0.0, 0.1, 0.2, 0.2, 0.1};  // the 0 N tick holds 0.2 mJ
  for (int n = 0; n < 5; ++n) {
    run_force_chain(s, config, p, {0, 0, model[n]}, {}, 0.0, {0, 0, z[n]}, 0.001);
    EXPECT_NEAR(s.passivity.energy_mJ, energy[n], 1e-12) << n;
  }
  reset_force_chain(s);  // a real reset does restart it
  EXPECT_EQ(s.passivity.energy_mJ, 0.0);
}

TEST(ForceChain, UnderADelayTheObserverPairsTheForceInFlight) {
  // A transport delay of 2 ms at 1 kHz: the force written at tick k is applied over
  // [k + 2, k + 3]. The limiter writes 1.6, 3.2, 4.8, 6.4, 8 N (step bound) while the device
  // moves 0.1 mm out a tick; the travel over [n - 1, n] is pushed by what was written at n - 3,
  // nothing before the first force arrives.
  DeviceProfile p = stiff_profile();
  p.damping_N_s_per_mm = 0.0;
  p.transport_delay_s = 0.002;
  ForceChainConfig config = limiter();
  config.passivity = true;
  ForceChainState s;
  const double written[] = {1.6, 3.2, 4.8, 6.4, 8.0, 8.0};
  const double energy[] = {0.0, 0.0, 0.0, -0.16, -0.48, -0.96};  // -0.1 × (1.6, +3.2, +4.8)
  for (int n = 0; n < 6; ++n) {
    const ForceChainOutput out =
        run_force_chain(s, config, p, {0, 0, 100}, {}, 0.0, {0, 0, 0.1 * n}, 0.001);
    EXPECT_NEAR(out.force.z, written[n], 1e-9) << n;
    EXPECT_NEAR(s.passivity.energy_mJ, energy[n], 1e-9) << n;
  }
}

}  // namespace
}  // namespace palp
