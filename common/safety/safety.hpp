// Device profiles and the safety filters applied after the force model (spec: device limits
// apply after the model, per device profile; offline runs apply none unless asked).
//
// Every filter is a pure function: the previous output and device position come in as
// arguments, the filtered value and status bits go out; nothing is remembered in between.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "base/vec.hpp"

namespace palp {

// Limits of a class of haptic device, for rendering at 1 kHz. Values are of the public
// datasheet class of each device (see docs and safety.cpp); they bound what palp sends, they do
// not claim to describe a particular unit.
struct DeviceProfile {
  std::string_view name;  // "touch", "falcon", "phantom-premium", "omega"
  std::string_view description;
  double max_force_N;             // peak force magnitude
  double max_stiffness_N_per_mm;  // largest stiffness the device renders stably at 1 kHz
  double max_force_rate_N_per_s;  // largest change of force per second
  double settle_rate_N_per_s;     // change per second allowed on top of the stiffness limit,
                                  // so a held force still reaches the model's while at rest
  int dof;                        // 3: force only (torque is dropped); 6: force and torque
  double max_torque_Nmm;          // torque magnitude limit (dof 6)
  double damping_N_s_per_mm = 0;  // largest damping the device renders (CHAI3D's maxLinearDamping)
  // Transport delay: from reading a position to the force computed from it reaching the motors,
  // beyond the one tick over which a written force is held (0: none known). The force chain
  // widens the coupling's damping and lines its passivity observer up by it (force_chain.hpp).
  double transport_delay_s = 0;
};

// The profile palpd applies to a device that declares nothing when no profile is named: the
// most conservative class (Touch: 3.3 N).
inline constexpr std::string_view kDefaultProfileName = "touch";
const DeviceProfile& default_device_profile();
// `profile` with its force (and the rates that scale with it) lowered to what the device itself
// declares (`declared_max_force_N` > 0; 0 or less: nothing declared, `profile` unchanged).
DeviceProfile with_declared_force(const DeviceProfile& profile, double declared_max_force_N);

// What a device declares about itself (0: not declared).
struct DeclaredLimits {
  double max_force_N = 0;
  double max_stiffness_N_per_mm = 0;
  double damping_N_s_per_mm = 0;
};
// `profile` lowered, field by field, to what the device declares: never raised.
DeviceProfile with_declared(const DeviceProfile& profile, const DeclaredLimits& declared);

std::span<const DeviceProfile> device_profiles();
// nullptr when unknown.
const DeviceProfile* find_device_profile(std::string_view name);
// UsageError naming the known profiles when unknown.
const DeviceProfile& device_profile(std::string_view name);

enum SafetyStatus : std::uint32_t {
  kSafetyOk = 0,
  kSafetyNonFinite = 1u << 0,         // a NaN or infinity came in: output zeroed
  kSafetyForceClamped = 1u << 1,      // force magnitude cut to max_force_N
  kSafetyStiffnessLimited = 1u << 2,  // force change cut by the stiffness limit
  kSafetyRateLimited = 1u << 3,       // force change cut by the rate limit
  kSafetyTorqueClamped = 1u << 4,     // torque magnitude cut to max_torque_Nmm
  kSafetyTorqueDropped = 1u << 5,     // non-zero torque on a 3-DOF device
  kSafetyEngaging = 1u << 6,          // force held off or ramping in (engagement.hpp)
  kSafetyPassivity = 1u << 7,         // the passivity controller damped (passivity.hpp)
};

struct Filtered {
  Vec3d value{};
  std::uint32_t status = kSafetyOk;
};

// Any non-finite component: zero vector and kSafetyNonFinite.
Filtered finite_or_zero(const Vec3d& v);
// Magnitude cut to `max` keeping the direction; `flag` is reported when cut.
Filtered clamp_magnitude(const Vec3d& v, double max, std::uint32_t flag);
// Moves from `prev` toward `target` by at most `max_step` (the direction of the change is kept);
// `flag` is reported when cut. max_step <= 0 or NaN holds prev.
Filtered limit_step(const Vec3d& target, const Vec3d& prev, double max_step, std::uint32_t flag);
// Force clamp: |f| <= max_force_N.
Filtered clamp_force(const Vec3d& f, double max_force_N);
// The factor clamp_magnitude(v, max, ...) scales v by: 1 within max, max / |v| beyond, 0 when max
// <= 0 (so a part of v, scaled by it, is that part of the clamped vector: force_chain.hpp).
double clamp_scale(const Vec3d& v, double max);
// The fraction of the way from `prev` to `target` limit_step(target, prev, max_step, ...) moves:
// 1 when not cut (or target == prev), max_step / |target - prev| when cut, 0 when max_step <= 0.
// Its output is prev + s (target - prev); a part of target and of prev follows the same line.
double step_fraction(const Vec3d& target, const Vec3d& prev, double max_step);
// Stiffness limit: |f - f_prev| <= max_stiffness * |x - x_prev| + slack_N, i.e. the force may
// not change faster per millimetre of device travel since the previous tick than the device
// renders stably; slack_N (settle_rate * dt in apply_device_limits) lets a limited force settle.
Filtered limit_stiffness(const Vec3d& f, const Vec3d& f_prev, const Vec3d& x, const Vec3d& x_prev,
                         double max_stiffness_N_per_mm, double slack_N);
// Rate limit: |f - f_prev| <= max_rate * dt. dt is taken in [0, kMaxFilterDt].
Filtered limit_rate(const Vec3d& f, const Vec3d& f_prev, double dt, double max_rate_N_per_s);

// Longest tick the step limits honour (s): a pause in ticking does not license a jump.
inline constexpr double kMaxFilterDt = 0.01;

struct SafetyInput {
  Vec3d force{};          // the model's device force (N)
  Vec3d torque{};         // the model's device torque (N·mm)
  Vec3d prev_force{};     // what was sent last tick (output of the previous call)
  Vec3d position{};       // device position now (mm)
  Vec3d prev_position{};  // device position at the previous tick
  double dt = 0.001;      // seconds since the previous tick
};

struct SafetyOutput {
  Vec3d force{};
  Vec3d torque{};
  std::uint32_t status = kSafetyOk;
};

// Torque: dropped (kSafetyTorqueDropped when non-zero) on a 3-DOF device, magnitude-clamped on
// a 6-DOF one; the force of the output is zero.
SafetyOutput limit_torque(const DeviceProfile& profile, const Vec3d& torque);
// What holds for any output, with no memory: a non-finite force or torque zeroes both; force
// clamp; torque as limit_torque. (The coupled chain's limits: the virtual coupling bounds the
// stiffness, so no stiffness or rate limit on the model's force.)
SafetyOutput apply_output_limits(const DeviceProfile& profile, const Vec3d& force,
                                 const Vec3d& torque);

// The whole chain, in order: a non-finite force or torque zeroes both at once (and stops);
// force clamp; stiffness limit; rate limit; force clamp again (prev may exceed a new profile);
// torque dropped on 3-DOF devices, clamped on 6-DOF ones.
SafetyOutput apply_device_limits(const DeviceProfile& profile, const SafetyInput& in);

}  // namespace palp
