#include "safety/safety.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "base/errors.hpp"

namespace palp {
namespace {

// Datasheet-class values, from CHAI3D's device specifications (chai3d.org, BSD), which the
// haptics community uses as the reference set (force N, stiffness N/m -> N/mm, damping
// N s/m -> N s/mm):
//   touch            3D Systems Touch (CHAI3D CPhantomDevices.cpp, "Touch"): 3.3 N,
//                    400 N/m, 4 N s/m. 3-DOF force. palpd's default for a device that declares
//                    nothing.
//   falcon           Novint Falcon (CHAI3D CFalconDevice.cpp): 8 N, 3000 N/m, 20 N s/m.
//                    3-DOF force.
//   phantom-premium  PHANToM Premium 1.5 6DOF (CHAI3D CPhantomDevices.cpp): 8.5 N, 800 N/m,
//                    5 N s/m, 0.188 N m = 188 N mm torque. 6-DOF output.
//   omega            Force Dimension omega.3 (CHAI3D CDeltaDevices.cpp): 12 N, 5000 N/m,
//                    40 N s/m. 3-DOF force.
// Transport delay: the Falcon's USB exchange (request / reply through its FTDI bridge, which
// sends a packet each 1 ms latency period: server/devices/falcon_device.hpp) takes 1-2 ms; the
// profile takes 2 ms. The others declare none (not known to palp).
// No datasheet gives a force rate: palp allows the full force within 5 ms (5 ticks at 1 kHz)
// and lets a stiffness-limited force settle at full force per second.
constexpr std::array<DeviceProfile, 4> kProfiles{{
    {"touch", "3D Systems Touch class, 3-DOF", 3.3, 0.4, 660.0, 3.3, 3, 0.0, 0.004},
    {"falcon", "Novint Falcon class, 3-DOF", 8.0, 3.0, 1600.0, 8.0, 3, 0.0, 0.020, 0.002},
    {"phantom-premium", "PHANToM Premium 1.5 class, 6-DOF", 8.5, 0.8, 1700.0, 8.5, 6, 188.0, 0.005},
    {"omega", "Force Dimension omega.3 class, 3-DOF", 12.0, 5.0, 2400.0, 12.0, 3, 0.0, 0.040},
}};

}  // namespace

std::span<const DeviceProfile> device_profiles() {
  return kProfiles;
}

const DeviceProfile* find_device_profile(std::string_view name) {
  for (const DeviceProfile& p : kProfiles)
    if (p.name == name) return &p;
  return nullptr;
}

const DeviceProfile& device_profile(std::string_view name) {
  if (const DeviceProfile* p = find_device_profile(name)) return *p;
  std::string known;
  for (const DeviceProfile& p : kProfiles)
    known += (known.empty() ? "" : ", ") + std::string(p.name);
  throw UsageError("device '" + std::string(name) + "' is not one of " + known);
}

const DeviceProfile& default_device_profile() {
  return device_profile(kDefaultProfileName);
}

DeviceProfile with_declared_force(const DeviceProfile& profile, double declared_max_force_N) {
  if (!(declared_max_force_N > 0.0) || declared_max_force_N >= profile.max_force_N) return profile;
  DeviceProfile p = profile;
  const double ratio = declared_max_force_N / profile.max_force_N;
  p.max_force_N = declared_max_force_N;
  p.max_force_rate_N_per_s *= ratio;  // still the full force within 5 ms, no faster
  p.settle_rate_N_per_s *= ratio;
  return p;
}

DeviceProfile with_declared(const DeviceProfile& profile, const DeclaredLimits& declared) {
  DeviceProfile p = with_declared_force(profile, declared.max_force_N);
  if (declared.max_stiffness_N_per_mm > 0.0)
    p.max_stiffness_N_per_mm = std::min(p.max_stiffness_N_per_mm, declared.max_stiffness_N_per_mm);
  if (declared.damping_N_s_per_mm > 0.0)
    p.damping_N_s_per_mm = std::min(p.damping_N_s_per_mm, declared.damping_N_s_per_mm);
  return p;
}

Filtered finite_or_zero(const Vec3d& v) {
  if (is_finite(v)) return {v, kSafetyOk};
  return {Vec3d{}, kSafetyNonFinite};
}

Filtered clamp_magnitude(const Vec3d& v, double max, std::uint32_t flag) {
  const double m = norm(v);
  if (!(max > 0.0)) return {Vec3d{}, m > 0.0 ? flag : kSafetyOk};
  if (m <= max) return {v, kSafetyOk};
  return {v * (max / m), flag};
}

Filtered limit_step(const Vec3d& target, const Vec3d& prev, double max_step, std::uint32_t flag) {
  const Vec3d delta = target - prev;
  const double m = norm(delta);
  if (m == 0.0) return {target, kSafetyOk};
  if (!(max_step > 0.0)) return {prev, flag};
  if (m <= max_step) return {target, kSafetyOk};
  return {prev + delta * (max_step / m), flag};
}

Filtered clamp_force(const Vec3d& f, double max_force_N) {
  return clamp_magnitude(f, max_force_N, kSafetyForceClamped);
}

double clamp_scale(const Vec3d& v, double max) {
  const double m = norm(v);
  if (!(max > 0.0)) return 0.0;
  return m <= max ? 1.0 : max / m;
}

double step_fraction(const Vec3d& target, const Vec3d& prev, double max_step) {
  const double m = norm(target - prev);
  if (m == 0.0) return 1.0;
  if (!(max_step > 0.0)) return 0.0;
  return m <= max_step ? 1.0 : max_step / m;
}

Filtered limit_stiffness(const Vec3d& f, const Vec3d& f_prev, const Vec3d& x, const Vec3d& x_prev,
                         double max_stiffness_N_per_mm, double slack_N) {
  double travel = norm(x - x_prev);
  if (!std::isfinite(travel)) travel = 0.0;
  const double slack = std::isfinite(slack_N) ? std::max(slack_N, 0.0) : 0.0;
  return limit_step(f, f_prev, max_stiffness_N_per_mm * travel + slack, kSafetyStiffnessLimited);
}

Filtered limit_rate(const Vec3d& f, const Vec3d& f_prev, double dt, double max_rate_N_per_s) {
  const double t = std::isfinite(dt) ? std::clamp(dt, 0.0, kMaxFilterDt) : 0.0;
  return limit_step(f, f_prev, max_rate_N_per_s * t, kSafetyRateLimited);
}

SafetyOutput limit_torque(const DeviceProfile& profile, const Vec3d& torque) {
  SafetyOutput out;
  if (profile.dof < 6) {  // none on a 3-DOF device
    if (norm(torque) > 0.0) out.status |= kSafetyTorqueDropped;
    return out;
  }
  const Filtered t = clamp_magnitude(torque, profile.max_torque_Nmm, kSafetyTorqueClamped);
  out.status |= t.status;
  out.torque = t.value;
  return out;
}

SafetyOutput apply_output_limits(const DeviceProfile& profile, const Vec3d& force,
                                 const Vec3d& torque) {
  SafetyOutput out;
  if (!is_finite(force) || !is_finite(torque)) {
    out.status = kSafetyNonFinite;
    return out;
  }
  const Filtered f = clamp_force(force, profile.max_force_N);
  const SafetyOutput t = limit_torque(profile, torque);
  out.force = f.value;
  out.torque = t.torque;
  out.status = f.status | t.status;
  return out;
}

SafetyOutput apply_device_limits(const DeviceProfile& profile, const SafetyInput& in) {
  SafetyOutput out;
  // Non-finite input: let go at once.
  if (!is_finite(in.force) || !is_finite(in.torque)) {
    out.status = kSafetyNonFinite;
    return out;
  }
  Filtered prev = finite_or_zero(in.prev_force);
  out.status |= prev.status;
  const double dt = std::isfinite(in.dt) ? std::clamp(in.dt, 0.0, kMaxFilterDt) : 0.0;

  // Force: clamp the target, limit its change per millimetre and per second, clamp again.
  Filtered f = clamp_force(in.force, profile.max_force_N);
  out.status |= f.status;
  f = limit_stiffness(f.value, prev.value, in.position, in.prev_position,
                      profile.max_stiffness_N_per_mm, profile.settle_rate_N_per_s * dt);
  out.status |= f.status;
  f = limit_rate(f.value, prev.value, dt, profile.max_force_rate_N_per_s);
  out.status |= f.status;
  f = clamp_force(f.value, profile.max_force_N);
  out.status |= f.status;
  out.force = f.value;

  const SafetyOutput torque = limit_torque(profile, in.torque);
  out.status |= torque.status;
  out.torque = torque.torque;
  return out;
}

}  // namespace palp
