// The force chain from model to device: see force_chain.hpp.
#include "safety/force_chain.hpp"

#include <algorithm>
#include <cmath>

namespace palp {

Vec3d force_chain_tool(const ForceChainState& s, const ForceChainConfig& config,
                       const Vec3d& device_position) {
  return config.coupling ? coupled_tool(s.coupling, device_position) : device_position;
}

namespace {

// The passive part's output plus the known active force (skipped when there is none, so that
// -0 + 0 cannot turn a zero's sign: the chain without one is the one before, bit for bit).
Vec3d with_active(const Vec3d& passive_out, const Vec3d& active) {
  return active == Vec3d{} ? passive_out : passive_out + active;
}

// The first stage on the model's passive part (model - active): the coupling (model at the virtual
// tool -> spring-damper) or, with it off, the stiffness limiter on its own previous output; then
// the active force joins it and the clamp and torque limits apply to the total. `active` comes
// back as its part of that output (scaled by the clamp; 0 when the output is zeroed).
SafetyOutput first_stage(ForceChainState& s, const ForceChainConfig& config,
                         const DeviceProfile& limits, const Vec3d& passive,
                         const Vec3d& model_torque, double model_stiffness, const Vec3d& position,
                         double t, Vec3d& active, ForceChainOutput& out) {
  SafetyOutput result;
  if (config.coupling) {
    const CouplingGains gains = coupling_gains(limits, t);
    const CouplingOutput coupled = couple(s.coupling, gains, passive, model_stiffness, position, t);
    out.coupling_stiffness_N_per_mm = gains.stiffness_N_per_mm;
    const Vec3d total = with_active(coupled.force, active);
    result = apply_output_limits(limits, total, model_torque);
    active = (result.status & kSafetyNonFinite) ? Vec3d{}
                                                : active * clamp_scale(total, limits.max_force_N);
    return result;
  }
  SafetyInput in;
  in.force = passive;
  in.torque = model_torque;
  in.prev_force = s.limited_prev;
  in.position = position;
  in.prev_position = s.have_prev ? s.position_prev : position;
  in.dt = t;
  result = apply_device_limits(limits, in);
  s.limited_prev = result.force;  // the limiter follows its own (passive) output
  if (active == Vec3d{} || (result.status & kSafetyNonFinite)) {
    active = Vec3d{};
    return result;
  }
  const Vec3d total = result.force + active;
  const Filtered clamped = clamp_force(total, limits.max_force_N);
  active = active * clamp_scale(total, limits.max_force_N);
  result.force = clamped.value;
  result.status |= clamped.status;
  return result;
}

// The passivity controller on `force` (the observer has already seen this tick's port): once
// engaged and while a force is rendered (with nothing rendered a damper alone would brake, or
// pull, a hand in free space); a damper that would reverse the force lets go instead.
// The damper is the passive part's; a let-go writes none of the active part either.
Vec3d passivity_stage(const ForceChainState& s, const ForceChainConfig& config,
                      const DeviceProfile& limits, const Vec3d& force, double t, Vec3d& active,
                      ForceChainOutput& out) {
  const bool engaged = !config.engage || s.engagement.engaged();
  if (!config.passivity || !engaged || force == Vec3d{}) return force;
  const PassivityOutput pc =
      passivity_control(s.passivity, force, s.velocity, t, limits.damping_N_s_per_mm);
  if (!(pc.damping_N_s_per_mm > 0.0)) return force;
  Vec3d damped = pc.force;
  if (dot(damped, force) < 0.0) damped = active = Vec3d{};  // never pull
  out.status |= kSafetyPassivity;
  out.damping_N_s_per_mm = pc.damping_N_s_per_mm;
  // what taking (force - damped) off should dissipate over this tick; the observer sees what the
  // written force actually did, next tick
  out.dissipated_mJ = dot(force - damped, s.velocity) * t;
  return damped;
}

// The force applied over the tick just ended, and its active part: written last tick, or d ticks
// before that with the profile's transport delay of d ticks.
struct Applied {
  Vec3d force, active;
};
Applied applied_last_tick(const ForceChainState& s, const DeviceProfile& limits, double t) {
  const long d = t > 0.0 ? std::lround(transport_delay(limits) / t) : 0;
  if (d <= 0) return {s.written_prev, s.active_prev};
  const auto i = static_cast<std::size_t>(std::min<long>(d, kMaxDelayTicks) - 1);
  return {s.written_earlier[i], s.active_earlier[i]};
}

// The last stages: the step bound on what was written last tick, then the clamp; the active
// part follows the same line from its own last value and the same clamp factor.
Vec3d write_stage(ForceChainState& s, const DeviceProfile& limits, const Vec3d& force, double t,
                  Vec3d& active, ForceChainOutput& out) {
  const double max_step = limits.max_force_rate_N_per_s * std::clamp(t, 0.0, kMaxFilterDt);
  const Filtered stepped = limit_rate(force, s.written_prev, t, limits.max_force_rate_N_per_s);
  out.status |= stepped.status;
  const Filtered clamped = clamp_force(stepped.value, limits.max_force_N);
  out.status |= clamped.status;
  // (not cut, limit_step returns the target itself: the active part stays exactly as it was)
  const double along = step_fraction(force, s.written_prev, max_step);
  if (along < 1.0) active = s.active_prev + (active - s.active_prev) * along;
  active = active * clamp_scale(stepped.value, limits.max_force_N);
  return clamped.value;
}

}  // namespace

ForceChainOutput run_force_chain(ForceChainState& s, const ForceChainConfig& config,
                                 const DeviceProfile& limits, const Vec3d& model_force,
                                 const Vec3d& model_torque, double model_stiffness,
                                 const Vec3d& position, double dt, const Vec3d& active_force) {
  ForceChainOutput out;
  const double t = std::isfinite(dt) ? std::clamp(dt, 0.0, kMaxFilterDt) : 0.0;

  // the port, first: the force applied over the tick just ended (written last tick, or d ticks
  // before that under a transport delay), against the travel while it was held, its known
  // active part left out
  if (s.have_prev && is_finite(position)) {
    const Applied applied = applied_last_tick(s, limits, t);
    s.passivity =
        observe_port(s.passivity, applied.force, position - s.position_prev, applied.active);
  }
  out.port_energy_mJ = s.passivity.energy_mJ;

  // the model's passive part goes through the first stage, the active part joins after it (a
  // non-finite one makes the passive part non-finite too: nothing is rendered)
  Vec3d active = is_finite(active_force) ? active_force : Vec3d{};
  if (!is_finite(active_force)) out.status |= kSafetyNonFinite;
  const SafetyOutput limited = first_stage(s, config, limits, model_force - active_force,
                                           model_torque, model_stiffness, position, t, active, out);
  out.status |= limited.status;
  Vec3d force = limited.force, torque = limited.torque;

  // engagement: nothing until the model's force is small, then a ramp
  if (config.engage) {
    s.engagement = engage(s.engagement, norm(model_force), t, *config.engage);
    force = force * s.engagement.gain;
    torque = torque * s.engagement.gain;
    active = active * s.engagement.gain;
    if (!s.engagement.engaged()) {
      out.status |= kSafetyEngaging;
      // Not engaged: the virtual tool stays on the device, so engagement waits on the model's
      // force where the device is, and the coupling starts from rest once it engages.
      reset_coupling(s.coupling);
    }
  }

  // velocity, low-pass filtered (encoder steps differentiated are noise the damper must not see)
  if (s.have_prev && t > 0.0 && is_finite(position)) {
    const Vec3d raw = (position - s.position_prev) * (1.0 / t);
    const double a = t / (config.velocity_filter_s + t);
    s.velocity = s.velocity + (raw - s.velocity) * a;
  }

  force = passivity_stage(s, config, limits, force, t, active, out);

  // the step bound on what reaches the device, then the clamp
  out.force = write_stage(s, limits, force, t, active, out);
  out.torque = torque;
  out.active = active;
  std::copy_backward(s.written_earlier.begin(), s.written_earlier.end() - 1,
                     s.written_earlier.end());
  std::copy_backward(s.active_earlier.begin(), s.active_earlier.end() - 1, s.active_earlier.end());
  s.written_earlier[0] = s.written_prev;
  s.active_earlier[0] = s.active_prev;
  s.written_prev = out.force;
  s.active_prev = active;
  s.position_prev = position;
  s.have_prev = true;
  return out;
}

void reset_force_chain(ForceChainState& s) {
  s.limited_prev = Vec3d{};
  s.written_prev = Vec3d{};
  s.active_prev = Vec3d{};
  s.written_earlier.fill(Vec3d{});
  s.active_earlier.fill(Vec3d{});
  s.have_prev = false;
  s.velocity = Vec3d{};
  s.engagement = Engagement{};
  s.passivity = PassivityState{};
  reset_coupling(s.coupling);
}

}  // namespace palp
