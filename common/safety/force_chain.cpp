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

// The first stage: the coupling (model at the virtual tool -> spring-damper -> clamp and torque
// limits) or, with it off, the stiffness limiter on its own previous output.
SafetyOutput first_stage(ForceChainState& s, const ForceChainConfig& config,
                         const DeviceProfile& limits, const Vec3d& model_force,
                         const Vec3d& model_torque, double model_stiffness, const Vec3d& position,
                         double t, ForceChainOutput& out) {
  if (config.coupling) {
    const CouplingGains gains = coupling_gains(limits, t);
    const CouplingOutput coupled =
        couple(s.coupling, gains, model_force, model_stiffness, position, t);
    out.coupling_stiffness_N_per_mm = gains.stiffness_N_per_mm;
    return apply_output_limits(limits, coupled.force, model_torque);
  }
  SafetyInput in;
  in.force = model_force;
  in.torque = model_torque;
  in.prev_force = s.limited_prev;
  in.position = position;
  in.prev_position = s.have_prev ? s.position_prev : position;
  in.dt = t;
  const SafetyOutput limited = apply_device_limits(limits, in);
  s.limited_prev = limited.force;
  return limited;
}

// The passivity controller on `force` (the observer has already seen this tick's port): once
// engaged and while a force is rendered (with nothing rendered a damper alone would brake, or
// pull, a hand in free space); a damper that would reverse the force lets go instead.
Vec3d passivity_stage(const ForceChainState& s, const ForceChainConfig& config,
                      const DeviceProfile& limits, const Vec3d& force, double t,
                      ForceChainOutput& out) {
  const bool engaged = !config.engage || s.engagement.engaged();
  if (!config.passivity || !engaged || force == Vec3d{}) return force;
  const PassivityOutput pc =
      passivity_control(s.passivity, force, s.velocity, t, limits.damping_N_s_per_mm);
  if (!(pc.damping_N_s_per_mm > 0.0)) return force;
  Vec3d damped = pc.force;
  if (dot(damped, force) < 0.0) damped = Vec3d{};  // never pull
  out.status |= kSafetyPassivity;
  out.damping_N_s_per_mm = pc.damping_N_s_per_mm;
  // what taking (force - damped) off should dissipate over this tick; the observer sees what the
  // written force actually did, next tick
  out.dissipated_mJ = dot(force - damped, s.velocity) * t;
  return damped;
}

// The force applied over the tick just ended: written last tick, or d ticks before that with the
// profile's transport delay of d ticks.
Vec3d applied_last_tick(const ForceChainState& s, const DeviceProfile& limits, double t) {
  const long d = t > 0.0 ? std::lround(transport_delay(limits) / t) : 0;
  if (d <= 0) return s.written_prev;
  return s.written_earlier[static_cast<std::size_t>(std::min<long>(d, kMaxDelayTicks) - 1)];
}

}  // namespace

ForceChainOutput run_force_chain(ForceChainState& s, const ForceChainConfig& config,
                                 const DeviceProfile& limits, const Vec3d& model_force,
                                 const Vec3d& model_torque, double model_stiffness,
                                 const Vec3d& position, double dt) {
  ForceChainOutput out;
  const double t = std::isfinite(dt) ? std::clamp(dt, 0.0, kMaxFilterDt) : 0.0;

  // the port, first: the force applied over the tick just ended (written last tick, or d ticks
  // before that under a transport delay), against the travel while it was held
  if (s.have_prev && is_finite(position))
    s.passivity =
        observe_port(s.passivity, applied_last_tick(s, limits, t), position - s.position_prev);
  out.port_energy_mJ = s.passivity.energy_mJ;

  const SafetyOutput limited =
      first_stage(s, config, limits, model_force, model_torque, model_stiffness, position, t, out);
  out.status |= limited.status;
  Vec3d force = limited.force, torque = limited.torque;

  // engagement: nothing until the model's force is small, then a ramp
  if (config.engage) {
    s.engagement = engage(s.engagement, norm(model_force), t, *config.engage);
    force = force * s.engagement.gain;
    torque = torque * s.engagement.gain;
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

  force = passivity_stage(s, config, limits, force, t, out);

  // the step bound on what reaches the device, then the clamp
  const Filtered stepped = limit_rate(force, s.written_prev, t, limits.max_force_rate_N_per_s);
  out.status |= stepped.status;
  const Filtered clamped = clamp_force(stepped.value, limits.max_force_N);
  out.status |= clamped.status;
  out.force = clamped.value;
  out.torque = torque;
  std::copy_backward(s.written_earlier.begin(), s.written_earlier.end() - 1,
                     s.written_earlier.end());
  s.written_earlier[0] = s.written_prev;
  s.written_prev = out.force;
  s.position_prev = position;
  s.have_prev = true;
  return out;
}

void reset_force_chain(ForceChainState& s) {
  s.limited_prev = Vec3d{};
  s.written_prev = Vec3d{};
  s.written_earlier.fill(Vec3d{});
  s.have_prev = false;
  s.velocity = Vec3d{};
  s.engagement = Engagement{};
  s.passivity = PassivityState{};
  reset_coupling(s.coupling);
}

}  // namespace palp
