// The force chain from model to device: engagement scales the limiter's output without slowing
// it (the limiter follows its own output), the step bound holds on what is written, the
// passivity controller never pulls, and the passivity observer sums the force actually written
// against the travel while it was held (expected energies summed by hand in each test). With a
// known active force (issue 39, the pulse): its work is the known input's, the passive part's
// accounting is kept exactly, an unstable passive part is still caught, and the limits hold on
// the total.
#include "safety/force_chain.hpp"

#include <gtest/gtest.h>

#include <cmath>

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

// The pulse of the tests below: f_a = A (1 - cos θ) / 2 along z, θ = 2π 1.2 Hz t (0 at t = 0, so
// engagement can start), and a hand that yields to it a quarter period late about `rest`, z =
// rest - r sin θ: the pulse does A r π / 2 of work on the hand each beat.
constexpr double kPi = 3.14159265358979323846;
constexpr double kBeatHz = 1.2, kTick = 0.001;
double pulse_at(int n, double amplitude) {
  return amplitude * (1.0 - std::cos(2 * kPi * kBeatHz * n * kTick)) / 2.0;
}
double hand_at(int n, double rest, double r) {
  return rest - r * std::sin(2 * kPi * kBeatHz * n * kTick);
}

TEST(ForceChain, APurePulseOverAMovingHandLeavesTheObserverAtZero) {
  // palpd's chain (coupling, engagement, controller with the profile's damping, the falcon's 2 ms
  // transport delay): a position-independent 0.5 N pulse is the whole model force. The coupling
  // renders no passive force (free motion writes exactly 0), so the written force is the pulse's
  // alone: the observer reads exactly 0 every tick and the controller never damps, and after
  // the 5-tick engagement ramp the pulse reaches the device intact.
  const DeviceProfile p = device_profile("falcon");
  ForceChainConfig config;
  config.engage = EngageParams{0.2, 0.005};
  config.passivity = true;
  ForceChainState s;
  for (int n = 0; n < 3000; ++n) {
    const Vec3d pulse{0, 0, pulse_at(n, 0.5)};
    const ForceChainOutput out =
        run_force_chain(s, config, p, pulse, {}, 0.0, {0, 0, hand_at(n, 0.0, 2.0)}, kTick, pulse);
    ASSERT_EQ(s.passivity.energy_mJ, 0.0) << n;
    ASSERT_EQ(out.damping_N_s_per_mm, 0.0) << n;
    ASSERT_EQ(out.force, out.active) << n;
    if (n >= 6) {
      ASSERT_NEAR(out.force.z, pulse.z, 1e-12) << n;
    }
  }
}

TEST(ForceChain, APulseNotDeclaredActiveIsDampedAway) {
  // The same pulse through the limiter chain (it passes unchanged: nothing binds) with the
  // observer alone: declared, the observer stays at 0; not declared (main's accounting), it falls
  // by the pulse's work on the hand, A r π / 2 a beat (3 beats: within 1 %), and the controller,
  // given damping, damps: the pulse's rendering shrinks.
  DeviceProfile p = stiff_profile();
  p.damping_N_s_per_mm = 0.0;
  ForceChainConfig config = limiter();
  config.passivity = true;
  ForceChainState known, unknown;
  const int beat = static_cast<int>(std::lround(1.0 / (kBeatHz * kTick)));
  for (int n = 0; n <= 3 * beat; ++n) {
    const Vec3d pulse{0, 0, pulse_at(n, 0.5)}, at{0, 0, hand_at(n, 0.0, 2.0)};
    EXPECT_EQ(run_force_chain(known, config, p, pulse, {}, 0.0, at, kTick, pulse).force, pulse);
    run_force_chain(unknown, config, p, pulse, {}, 0.0, at, kTick);
  }
  EXPECT_EQ(known.passivity.energy_mJ, 0.0);
  const double work = 3 * 0.5 * 2.0 * kPi / 2;
  EXPECT_NEAR(unknown.passivity.energy_mJ, -work, 0.01 * work);
  p.damping_N_s_per_mm = 0.02;
  const Vec3d pulse{0, 0, 0.5}, at{0, 0, hand_at(3 * beat + 1, 0.0, 2.0)};
  const ForceChainOutput damped = run_force_chain(unknown, config, p, pulse, {}, 0.0, at, kTick);
  EXPECT_GT(damped.damping_N_s_per_mm, 0.0);
  EXPECT_EQ(run_force_chain(known, config, p, pulse, {}, 0.0, at, kTick, pulse).damping_N_s_per_mm,
            0.0);
}

// A spring pressed by a hand, z <= 0 under the skin: F = -k z (out, N), k = 0.5 N/mm, the hand
// resting 3 mm in (1.5 N) at first, then 0-3 mm further with the beat (z from -3 to -6 mm).
double pressed_at(int n) {
  return -3.0 - 1.5 * (1.0 - std::cos(2 * kPi * kBeatHz * n * kTick));
}

TEST(ForceChain, ASpringPlusThePulseKeepsTheSpringsAccounting) {
  // The limiter chain (nothing binds) writes the spring's force plus the pulse. The spring's own
  // accounting, the sampled spring's (z_n-1 (z_n - z_n-1) = (z_n² - z_n-1²) / 2 - (Δz)² / 2):
  //   E(N) = k/2 (z_N² - z_0²) - k/2 Σ (z_n - z_n-1)²,
  // with the 0.4 N pulse on exactly as with it off. With the coupling, the chain's energy with
  // the pulse is the chain's without it (the coupling sees the same passive force).
  const double k = 0.5;
  DeviceProfile p = stiff_profile();
  p.damping_N_s_per_mm = 0.0;
  for (const bool coupled : {false, true}) {
    ForceChainConfig config = coupled ? ForceChainConfig{} : limiter();
    config.passivity = true;
    ForceChainState with_pulse, without;
    double leak = 0.0;
    for (int n = 0; n < 4000; ++n) {
      const double z = pressed_at(n);
      if (n > 0) leak += (z - pressed_at(n - 1)) * (z - pressed_at(n - 1));
      const Vec3d spring{0, 0, -k * z}, pulse{0, 0, pulse_at(n, 0.4)};
      const double slope = coupled ? k : 0.0;
      run_force_chain(with_pulse, config, p, spring + pulse, {}, slope, {0, 0, z}, kTick, pulse);
      run_force_chain(without, config, p, spring, {}, slope, {0, 0, z}, kTick);
      ASSERT_NEAR(with_pulse.passivity.energy_mJ, without.passivity.energy_mJ, 1e-9) << n;
    }
    const double z_end = pressed_at(3999), z0 = pressed_at(0);
    if (!coupled) {
      EXPECT_NEAR(with_pulse.passivity.energy_mJ, k / 2 * (z_end * z_end - z0 * z0) - k / 2 * leak,
                  1e-9);
    }
  }
}

TEST(ForceChain, AnUnstableSpringIsStillCaughtWithThePulseOn) {
  // Two active-unstable passive parts under the pulse: the spring with negative damping
  // F = -k z + b v (b = 0.08 N s/mm, v the backward difference), and the spring read 150 ticks
  // late, F = -k z(n - 150). The observer alone reads their own sums by hand with the pulse on,
  // E(n) = E(n-1) - F(n-1) Δz(n), which fall below 0 once they have given out more than the
  // press stored since the start (at most 6.75 mJ); given damping, the controller then damps
  // them tick for tick as without the pulse (the passive part pushes out by 0.6 N or more and the
  // damper takes at most 0.02 N s/mm x 11 mm/s, so it never lets go).
  const double k = 0.5, b = 0.08;
  DeviceProfile p = stiff_profile();
  for (const bool delayed : {false, true}) {
    const auto passive_at = [&](int n) {
      if (delayed) return -k * pressed_at(std::max(0, n - 150));
      const double v = n > 0 ? (pressed_at(n) - pressed_at(n - 1)) / kTick : 0.0;
      return -k * pressed_at(n) + b * v;
    };
    double expected = 0.0;
    long damped_ticks = 0;
    ForceChainConfig config = limiter();
    config.passivity = true;
    ForceChainState observed, with_pulse, without;
    for (int n = 0; n < 5000; ++n) {
      const double z = pressed_at(n);
      if (n > 0) expected -= passive_at(n - 1) * (z - pressed_at(n - 1));
      const Vec3d passive{0, 0, passive_at(n)}, pulse{0, 0, pulse_at(n, 0.5)};
      p.damping_N_s_per_mm = 0.0;
      run_force_chain(observed, config, p, passive + pulse, {}, 0.0, {0, 0, z}, kTick, pulse);
      ASSERT_NEAR(observed.passivity.energy_mJ, expected, 1e-9) << n;
      p.damping_N_s_per_mm = 0.02;
      const ForceChainOutput a =
          run_force_chain(with_pulse, config, p, passive + pulse, {}, 0.0, {0, 0, z}, kTick, pulse);
      const ForceChainOutput c =
          run_force_chain(without, config, p, passive, {}, 0.0, {0, 0, z}, kTick);
      ASSERT_NEAR(a.damping_N_s_per_mm, c.damping_N_s_per_mm, 1e-9) << n;
      ASSERT_NEAR(a.force.z - a.active.z, c.force.z, 1e-9) << n;
      if (a.damping_N_s_per_mm > 0.0) ++damped_ticks;
    }
    EXPECT_LT(expected, -1.0) << "the passive part gave out energy";
    EXPECT_GT(damped_ticks, 100) << delayed;
  }
}

TEST(ForceChain, TheLimitsHoldOnTheTotalWithThePulseAtItsLargest) {
  // palpd's chain on the falcon (8 N, 1.6 N a tick at 1 kHz): a 7.8 N press plus the 0.5 N
  // pulse. Every tick: |f| <= 8 N and |Δf| <= 1.6 N. At the top of the beat the clamp cuts the
  // 8.3 N total to 8 N and the pulse's part to 0.5 x 8 / 8.3 N with it.
  DeviceProfile p = device_profile("falcon");
  p.transport_delay_s = 0.0;
  ForceChainConfig config;
  config.passivity = true;
  ForceChainState s;
  Vec3d prev{};
  const int top = static_cast<int>(std::lround(0.5 / (kBeatHz * kTick)));  // θ = π
  for (int n = 0; n <= top; ++n) {
    const Vec3d pulse{0, 0, pulse_at(n, 0.5)};
    const ForceChainOutput out =
        run_force_chain(s, config, p, Vec3d{0, 0, 7.8} + pulse, {}, 0.0, {}, kTick, pulse);
    ASSERT_LE(norm(out.force), 8.0 + 1e-12) << n;
    ASSERT_LE(norm(out.force - prev), 1.6 + 1e-12) << n;
    prev = out.force;
    if (n == top) {
      EXPECT_NEAR(pulse.z, 0.5, 1e-5);
      EXPECT_NEAR(out.force.z, 8.0, 1e-12);
      EXPECT_NEAR(out.active.z, pulse.z * 8.0 / (7.8 + pulse.z), 1e-12);
    }
  }
  // A broken model's 100 N "pulse" arriving at once: still 1.6 N a tick, 8 N at most, and the
  // pulse's part never more than the written force.
  for (int n = 0; n < 10; ++n) {
    const Vec3d pulse{0, 0, 100.0};
    const ForceChainOutput out =
        run_force_chain(s, config, p, Vec3d{0, 0, 1.0} + pulse, {}, 0.0, {}, kTick, pulse);
    ASSERT_LE(norm(out.force), 8.0 + 1e-12) << n;
    ASSERT_LE(norm(out.force - prev), 1.6 + 1e-12) << n;
    ASSERT_LE(out.active.z, out.force.z + 1e-12) << n;
    prev = out.force;
  }
  // A non-finite pulse: flagged, nothing rendered from this tick's model, the written force comes
  // down by the step bound (8 -> 6.4 N), and the last pulse's part of it with it (by 1.6 / 8).
  const double active_before = s.active_prev.z;
  const ForceChainOutput bad =
      run_force_chain(s, config, p, {0, 0, 3}, {}, 0.0, {}, kTick, {0, 0, std::nan("")});
  EXPECT_NE(bad.status & kSafetyNonFinite, 0u);
  EXPECT_NEAR(bad.force.z, 8.0 - 1.6, 1e-12);
  EXPECT_NEAR(bad.active.z, active_before * (1.0 - 1.6 / 8.0), 1e-12);
}

}  // namespace
}  // namespace palp
