// The virtual coupling: see virtual_coupling.hpp.
#include "safety/virtual_coupling.hpp"

#include <algorithm>
#include <cmath>

namespace palp {
namespace {

constexpr double kSecantDecayS = 0.020;      // the secant estimate forgets over 20 ms
constexpr double kMinSecantStepMm = 1e-6;    // a shorter step gives no secant
constexpr double kMaxStiffnessNPerMm = 1e6;  // K is capped (a step's secant is huge, not inf)

}  // namespace

double transport_delay(const DeviceProfile& limits) {
  const double d = limits.transport_delay_s;
  return std::isfinite(d) ? std::clamp(d, 0.0, kMaxTransportDelayS) : 0.0;
}

CouplingGains coupling_gains(const DeviceProfile& limits, double dt) {
  CouplingGains g;
  // the lag the damping answers for: the tick, plus the transport delay
  const double t = std::isfinite(dt) ? std::clamp(dt, 1e-6, kMaxFilterDt) : 1e-3;
  const double lag = t + 2.0 * transport_delay(limits);  // see coupling_gains() in the header
  double k = std::max(0.0, limits.max_stiffness_N_per_mm);
  double b = 2.0 * k * lag;
  const double b_max = limits.damping_N_s_per_mm;
  if (b_max > 0.0 && b > b_max) {
    b = b_max;
    k = std::min(k, b_max / (2.0 * lag));  // B_c = 2 K_c (T + t_d) still
  }
  g.stiffness_N_per_mm = k;
  g.damping_N_s_per_mm = b;
  return g;
}

double passive_device_damping(const CouplingGains& gains, double dt, int delay_ticks) {
  const double lag = (std::max(0, delay_ticks) + 0.5) * dt;
  return gains.stiffness_N_per_mm * lag + std::fabs(gains.damping_N_s_per_mm);
}

Vec3d coupled_tool(const CouplingState& state, const Vec3d& device_position) {
  return state.have ? state.tool : device_position;
}

CouplingOutput couple(CouplingState& s, const CouplingGains& gains, const Vec3d& model_force,
                      double model_stiffness, const Vec3d& device_position, double dt) {
  CouplingOutput out;
  const double t = std::isfinite(dt) ? std::clamp(dt, 1e-6, kMaxFilterDt) : 1e-3;
  if (!is_finite(model_force) || !is_finite(device_position)) {
    reset_coupling(s);
    return out;
  }
  if (!s.have) {
    s.tool = device_position;
    s.device_prev = device_position;
    s.have = true;
  }
  const Vec3d tool = s.tool;
  // K: the model's slope, or the secant of its force along the tool's last step (decaying)
  s.secant_N_per_mm *= std::exp(-t / kSecantDecayS);
  if (s.have_model) {
    const Vec3d step = tool - s.tool_prev;
    const double len2 = dot(step, step);
    if (len2 > kMinSecantStepMm * kMinSecantStepMm) {
      const double secant = -dot(model_force - s.force_prev, step) / len2;
      if (secant > s.secant_N_per_mm) s.secant_N_per_mm = secant;
    }
  }
  const double k_model = std::isfinite(model_stiffness) ? std::max(0.0, model_stiffness) : 0.0;
  const double k_env = std::min(std::max(k_model, s.secant_N_per_mm), kMaxStiffnessNPerMm);
  // The direction "out" for the no-pull rule: the model's force, or the last one it had (just
  // out of contact the secant still slows the tool, which must not drag the device back in).
  const bool has_force = !(model_force == Vec3d{});
  if (has_force) s.out_direction = model_force;
  s.tool_prev = tool;
  s.force_prev = model_force;
  s.have_model = true;

  // the tool's implicit step, then the coupling's force on the device
  const double kc = gains.stiffness_N_per_mm, bc = gains.damping_N_s_per_mm;
  const Vec3d v_d = (device_position - s.device_prev) * (1.0 / t);
  const double denom = k_env + kc + bc / t;
  Vec3d delta = denom > 0.0
                    ? (model_force + kc * (device_position - tool) + bc * v_d) * (1.0 / denom)
                    : Vec3d{};
  // Never pull: where the linearised model would turn its force round (the tool leaving the
  // surface within the step), the tool takes the free step instead (no model force: F_dev = 0).
  bool free_step = !has_force && k_env == 0.0;  // nothing to render: exactly free
  if (free_step || dot(model_force - k_env * delta, s.out_direction) < 0.0) {
    const double free_denom = kc + bc / t;
    delta = free_denom > 0.0 ? (kc * (device_position - tool) + bc * v_d) * (1.0 / free_denom)
                             : Vec3d{};
    free_step = true;
  }
  s.tool = tool + delta;
  s.device_prev = device_position;
  out.force = kc * (s.tool - device_position) + bc * (delta * (1.0 / t) - v_d);
  // the free step's force is 0 but for rounding, which must not read as a (pulling) force
  if (free_step || dot(out.force, s.out_direction) < 0.0) out.force = Vec3d{};
  if (!is_finite(out.force) || !is_finite(s.tool)) {
    reset_coupling(s);
    out.force = Vec3d{};
  }
  return out;
}

void reset_coupling(CouplingState& s) {
  s = CouplingState{};
}

}  // namespace palp
