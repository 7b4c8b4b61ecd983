// Device profiles and the pure safety filters applied after the model: finite check, force
// clamp keeping the direction, stiffness and rate limits bounding the step, torque handling.
#include "safety/safety.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "base/errors.hpp"

namespace palp {
namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();
const double kInf = std::numeric_limits<double>::infinity();

TEST(DeviceProfiles, KnownProfiles) {
  ASSERT_GE(device_profiles().size(), 4u);
  // CHAI3D's device specifications (safety.cpp names the file of each).
  const DeviceProfile& touch = device_profile("touch");
  EXPECT_EQ(touch.max_force_N, 3.3);
  EXPECT_EQ(touch.max_stiffness_N_per_mm, 0.4);
  EXPECT_EQ(touch.damping_N_s_per_mm, 0.004);
  EXPECT_EQ(&default_device_profile(), &touch);
  const DeviceProfile& falcon = device_profile("falcon");
  EXPECT_EQ(falcon.dof, 3);
  EXPECT_NEAR(falcon.max_force_N, 8.0, 1.0);
  const DeviceProfile& phantom = device_profile("phantom-premium");
  EXPECT_EQ(phantom.dof, 6);
  EXPECT_DOUBLE_EQ(phantom.max_force_N, 8.5);
  EXPECT_DOUBLE_EQ(phantom.max_stiffness_N_per_mm, 0.8);
  EXPECT_DOUBLE_EQ(phantom.max_torque_Nmm, 188.0);
  EXPECT_GT(phantom.max_torque_Nmm, 0.0);
  const DeviceProfile& omega = device_profile("omega");
  EXPECT_DOUBLE_EQ(omega.max_force_N, 12.0);
  EXPECT_DOUBLE_EQ(omega.max_stiffness_N_per_mm, 5.0);
  EXPECT_DOUBLE_EQ(falcon.max_stiffness_N_per_mm, 3.0);
  EXPECT_DOUBLE_EQ(falcon.damping_N_s_per_mm, 0.020);
  for (const DeviceProfile& p : device_profiles()) {
    EXPECT_EQ(find_device_profile(p.name), &p);
    EXPECT_GT(p.max_force_N, 0.0);
    EXPECT_GT(p.max_stiffness_N_per_mm, 0.0);
    EXPECT_GT(p.max_force_rate_N_per_s, 0.0);
    EXPECT_GE(p.settle_rate_N_per_s, 0.0);
    EXPECT_TRUE(p.dof == 3 || p.dof == 6);
    EXPECT_GT(p.damping_N_s_per_mm, 0.0);
    EXPECT_NEAR(p.max_force_rate_N_per_s * 0.005, p.max_force_N, 1e-9);  // full force in 5 ms
  }
  EXPECT_EQ(find_device_profile("sigma7"), nullptr);
  EXPECT_THROW(device_profile("sigma7"), UsageError);
}

TEST(DeviceProfiles, TheDeviceDeclaresLessOnlyLowersTheLimits) {
  const DeviceProfile& falcon = device_profile("falcon");
  const DeviceProfile three = with_declared_force(falcon, 3.0);
  EXPECT_EQ(three.max_force_N, 3.0);
  EXPECT_EQ(three.max_force_rate_N_per_s, 600.0);  // still the full force in 5 ms
  EXPECT_EQ(three.settle_rate_N_per_s, 3.0);
  EXPECT_EQ(three.max_stiffness_N_per_mm, falcon.max_stiffness_N_per_mm);
  EXPECT_EQ(with_declared_force(falcon, 20.0).max_force_N, 8.0);  // more than the profile: no
  EXPECT_EQ(with_declared_force(falcon, 0.0).max_force_N, 8.0);   // nothing declared
  EXPECT_EQ(with_declared_force(falcon, std::nan("")).max_force_N, 8.0);
  // Whatever comes in, the chain's output stays within the declared force.
  SafetyInput in;
  in.force = {0, 0, 500};
  in.prev_force = {0, 0, 2.9};
  EXPECT_LE(norm(apply_device_limits(three, in).force), 3.0);
}

TEST(SafetyFilters, FiniteOrZero) {
  EXPECT_EQ(finite_or_zero({1, 2, 3}).value, (Vec3d{1, 2, 3}));
  EXPECT_EQ(finite_or_zero({1, 2, 3}).status, kSafetyOk);
  for (const Vec3d& bad : {Vec3d{kNaN, 0, 0}, Vec3d{0, kInf, 0}, Vec3d{0, 0, -kInf}}) {
    const Filtered f = finite_or_zero(bad);
    EXPECT_EQ(f.value, Vec3d{});
    EXPECT_EQ(f.status, kSafetyNonFinite);
  }
}

TEST(SafetyFilters, ClampKeepsDirection) {
  const Vec3d f{3.0, -4.0, 12.0};  // |f| = 13
  const Filtered c = clamp_force(f, 6.5);
  EXPECT_EQ(c.status, kSafetyForceClamped);
  EXPECT_NEAR(norm(c.value), 6.5, 1e-12);
  EXPECT_NEAR(norm(c.value - 0.5 * f), 0.0, 1e-12);
  const Filtered same = clamp_force(f, 13.5);
  EXPECT_EQ(same.status, kSafetyOk);
  EXPECT_EQ(same.value, f);
}

TEST(SafetyFilters, RateLimitBoundsTheStep) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  for (int n = 0; n < 1000; ++n) {
    const Vec3d target{u(rng), u(rng), u(rng)}, prev{u(rng), u(rng), u(rng)};
    const double dt = 0.001, rate = 1600.0;
    const Filtered r = limit_rate(target, prev, dt, rate);
    EXPECT_LE(norm(r.value - prev), rate * dt + 1e-9);
    if (norm(target - prev) <= rate * dt) {
      EXPECT_EQ(r.value, target);
      EXPECT_EQ(r.status, kSafetyOk);
    } else {
      EXPECT_EQ(r.status, kSafetyRateLimited);
      // The step goes straight toward the target.
      const Vec3d a = r.value - prev, b = target - prev;
      EXPECT_NEAR(dot(a, b), norm(a) * norm(b), 1e-9);
    }
  }
  // dt is taken in [0, kMaxFilterDt]: a long pause does not license a jump; a bad dt holds.
  EXPECT_NEAR(norm(limit_rate({100, 0, 0}, {}, 5.0, 1000.0).value), 1000.0 * kMaxFilterDt, 1e-9);
  EXPECT_EQ(limit_rate({5, 0, 0}, {1, 0, 0}, kNaN, 1000.0).value, (Vec3d{1, 0, 0}));
  EXPECT_EQ(limit_rate({5, 0, 0}, {1, 0, 0}, -1.0, 1000.0).value, (Vec3d{1, 0, 0}));
}

TEST(SafetyFilters, ClampScaleAndStepFractionDescribeTheFilters) {
  // |f| = 13: the clamp to 6.5 N scales it by 1/2, to 13.5 N by 1, to 0 by 0.
  const Vec3d f{3.0, -4.0, 12.0};
  EXPECT_EQ(clamp_scale(f, 6.5), 0.5);
  EXPECT_EQ(clamp_scale(f, 13.5), 1.0);
  EXPECT_EQ(clamp_scale(f, 0.0), 0.0);
  // From (1, 0, 0) toward (1, 0, 5): a step of 2 goes 2/5 of the way, 6 all of it, 0 none; a
  // target on prev is reached whatever the step.
  EXPECT_EQ(step_fraction({1, 0, 5}, {1, 0, 0}, 2.0), 0.4);
  EXPECT_EQ(step_fraction({1, 0, 5}, {1, 0, 0}, 6.0), 1.0);
  EXPECT_EQ(step_fraction({1, 0, 5}, {1, 0, 0}, 0.0), 0.0);
  EXPECT_EQ(step_fraction({1, 0, 0}, {1, 0, 0}, 0.0), 1.0);
  // and the filters' outputs lie where the fractions say
  const Vec3d prev{1, 0, 0}, target{1, 0, 5};
  EXPECT_EQ(limit_rate(target, prev, 0.001, 2000.0).value,
            prev + (target - prev) * step_fraction(target, prev, 2.0));
  EXPECT_EQ(clamp_force(f, 6.5).value, f * clamp_scale(f, 6.5));
}

TEST(SafetyFilters, StiffnessLimitBoundsForceChangePerTravel) {
  // 0.1 mm of travel at 3 N/mm allows 0.3 N (plus the slack).
  const Filtered s = limit_stiffness({5, 0, 0}, {1, 0, 0}, {0.1, 0, 0}, {0, 0, 0}, 3.0, 0.01);
  EXPECT_EQ(s.status, kSafetyStiffnessLimited);
  EXPECT_NEAR(s.value.x, 1.31, 1e-12);
  // No travel, no slack: held.
  EXPECT_EQ(limit_stiffness({5, 0, 0}, {1, 0, 0}, {}, {}, 3.0, 0.0).value, (Vec3d{1, 0, 0}));
  // Within the limit: passed through.
  const Filtered ok = limit_stiffness({1.2, 0, 0}, {1, 0, 0}, {0.1, 0, 0}, {}, 3.0, 0.0);
  EXPECT_EQ(ok.status, kSafetyOk);
  EXPECT_EQ(ok.value, (Vec3d{1.2, 0, 0}));
  // A non-finite position counts as no travel.
  EXPECT_EQ(limit_stiffness({5, 0, 0}, {1, 0, 0}, {kNaN, 0, 0}, {}, 3.0, 0.0).value,
            (Vec3d{1, 0, 0}));
}

TEST(ApplyDeviceLimits, NonFiniteZeroesAndFlags) {
  const DeviceProfile& p = device_profile("phantom-premium");
  SafetyInput in;
  in.prev_force = {2, 0, 0};
  in.force = {kNaN, 1, 1};
  in.torque = {10, 0, 0};
  SafetyOutput out = apply_device_limits(p, in);
  EXPECT_EQ(out.force, Vec3d{});
  EXPECT_EQ(out.torque, Vec3d{});
  EXPECT_TRUE(out.status & kSafetyNonFinite);
  in.force = {1, 1, 1};
  in.torque = {0, kInf, 0};
  out = apply_device_limits(p, in);
  EXPECT_EQ(out.force, Vec3d{});
  EXPECT_TRUE(out.status & kSafetyNonFinite);
}

TEST(ApplyDeviceLimits, ConvergesToClampedModelForceAndNeverExceedsLimits) {
  for (const DeviceProfile& p : device_profiles()) {
    // A constant 30 N model force with the device still, then moving.
    const Vec3d model{0.0, 18.0, 24.0};  // |model| = 30 N, beyond every profile
    Vec3d prev{}, pos{}, prev_pos{};
    const double dt = 0.001;
    for (int t = 0; t < 5000; ++t) {
      SafetyInput in{model, {}, prev, pos, prev_pos, dt};
      const SafetyOutput out = apply_device_limits(p, in);
      EXPECT_LE(norm(out.force), p.max_force_N + 1e-9);
      EXPECT_LE(norm(out.force - prev), p.max_force_rate_N_per_s * dt + 1e-9);
      EXPECT_LE(norm(out.force - prev), p.max_stiffness_N_per_mm * norm(pos - prev_pos) +
                                            p.settle_rate_N_per_s * dt + 1e-9);
      prev = out.force;
      prev_pos = pos;
      if (t > 1000) pos.z += 0.05;
    }
    // Clamped to max force along the model's direction.
    EXPECT_NEAR(norm(prev - (p.max_force_N / 30.0) * model), 0.0, 1e-9) << p.name;
  }
}

TEST(ApplyDeviceLimits, TorqueDroppedOn3DofClampedOn6Dof) {
  SafetyInput in;
  in.force = {0, 0, 0.001};
  in.torque = {3000.0, 0.0, 4000.0};  // 5000 N·mm
  const SafetyOutput f = apply_device_limits(device_profile("falcon"), in);
  EXPECT_EQ(f.torque, Vec3d{});
  EXPECT_TRUE(f.status & kSafetyTorqueDropped);
  const DeviceProfile& ph = device_profile("phantom-premium");
  const SafetyOutput t = apply_device_limits(ph, in);
  EXPECT_TRUE(t.status & kSafetyTorqueClamped);
  EXPECT_NEAR(norm(t.torque), ph.max_torque_Nmm, 1e-9);
  EXPECT_NEAR(t.torque.x / t.torque.z, 0.75, 1e-12);
  in.torque = {10.0, 0.0, 0.0};
  const SafetyOutput small = apply_device_limits(ph, in);
  EXPECT_EQ(small.torque, in.torque);
  EXPECT_FALSE(small.status & kSafetyTorqueClamped);
}

TEST(ApplyDeviceLimits, SmallChangesPassUntouched) {
  const DeviceProfile& p = device_profile("omega");
  SafetyInput in{{1.0, 0.0, 2.0}, {}, {1.0, 0.0, 1.999}, {0, 0, 0.01}, {0, 0, 0}, 0.001};
  const SafetyOutput out = apply_device_limits(p, in);
  EXPECT_EQ(out.force, in.force);
  EXPECT_EQ(out.status, kSafetyOk);
}

}  // namespace
}  // namespace palp
