// Passivity of the closed loop: a haptic device held by a hand, pressing into skin and onto bone,
// with the force model in the loop at update rates from 0.5 to 10 kHz: with saturation alone,
// the stiffness limiter palpd used first, and the virtual coupling that replaced it.
//
// One degree of freedom along the skin normal (the finger presses straight in; a flat skin, so
// the friction proxy stays put). Per device profile (common/model/safety.hpp) the device is a mass
// with viscous damping, its position is read through an encoder of finite resolution, and its force
// saturates at the profile's max force. The hand is a second mass coupled to the device by the
// grip (spring and damper), damped by the arm and pushing with a set force (ramped in over
// 0.5 s, then held). The model (finger:1, printed bone law, palp::tick) runs at the update rate
// on the quantised position; its force goes through either
//   saturation only   (clamp to max force: the device's own limit), or
//   the limiter       (palp::apply_device_limits: clamp, stiffness limit, rate limit),
//   rise-only limiter (a variant for comparison, not in palp: the limiter applied only while the
//                     force magnitude grows; a falling force passes with the clamp alone),
//   the coupling      (palp::run_force_chain with the virtual coupling only, no engagement or
//                     passivity controller: the model evaluated at the coupling's tool, the device
//                     given its spring-damper, then the clamp and step bound),
// and is held until the next update while both masses move (integrated at 100 kHz).
//
// Scenes: "skin" (a flat skin, no bone) and "bone" (a bone plate 10 mm under the skin; the bone
// law adds up to its 40 N cap). Measured over the last second of 2.5 s:
//   p2p_mm      peak-to-peak device position over the last 0.5 s (limit cycle amplitude)
//   inj_mW      energy injected by the rendered environment per second: the work its force did
//               on the device, corrected by the change of the passive (static) law's potential,
//               so a passive rendering gives 0 and a limit cycle fed by sampling gives > 0
//   stable      p2p below 0.05 mm plus two encoder steps, and no loss of contact
//
// Device class and hand assumptions: closed_loop.hpp.
//
// Writes passivity.csv (every run) and passivity_boundary.csv (per profile, limits, scene and
// hand force: the lowest tested rate from which every faster rate is stable; 20 kHz when even
// 10 kHz is not).
//
//   study_passivity [--out DIR] [--quick]
#include <cmath>
#include <cstdio>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "bench/closed_loop.hpp"
#include "bench/study_util.hpp"
#include "safety/force_chain.hpp"
#include "safety/safety.hpp"

namespace palp::study {
namespace {

constexpr double kRampS = 0.5, kEndS = 2.5, kMeasureS = 1.0, kCycleS = 0.5;

constexpr std::span<const DeviceClass> kDevices = std::span(kDeviceClasses);

enum class Limits { Saturation, Limiter, RiseOnly, Coupling };
const char* limits_name(Limits l) {
  return l == Limits::Saturation ? "saturation"
         : l == Limits::Limiter  ? "limiter"
         : l == Limits::RiseOnly ? "rise-only"
                                 : "coupling";
}

struct RunResult {
  double p2p_mm = 0.0, inj_mW = 0.0, mean_depth_mm = 0.0;
  bool lost_contact = false;
  bool stable = false;
};

RunResult run(Environment& env, const DeviceProfile& profile, const DeviceClass& dc,
              const Hand& hand, double rate, Limits limits, double push_N) {
  env.reset_state();
  const double period = 1.0 / rate;
  const int sub = std::max(1, static_cast<int>(std::lround(period / kSimDt)));
  const double dt = period / sub;
  // Start at rest with the pad 0.5 mm above the skin.
  double xd = env.device_z_for_depth(-0.5), vd = 0.0;
  double xh = xd, vh = 0.0;
  double f_out = 0.0, prev_force = 0.0, prev_pos = xd;
  const double q = dc.encoder_mm;
  ForceChainConfig coupling_only;  // no engagement, no passivity controller
  ForceChainState chain;
  const bool coupled = limits == Limits::Coupling;
  const double k_c = coupling_gains(profile, period).stiffness_N_per_mm;
  const auto potential = [&](double z) {
    return coupled ? env.coupled_potential(z, k_c, profile.max_force_N)
                   : env.potential(z, profile.max_force_N);
  };
  RunResult r;
  double work = 0.0, u_start = 0.0;  // J, over the measuring window
  bool measuring = false, touched = false;
  double cyc_min = 1e300, cyc_max = -1e300, depth_sum = 0.0;
  long depth_n = 0;
  const double t_measure = kEndS - kMeasureS, t_cycle = kEndS - kCycleS;
  for (double t = 0.0; t < kEndS; t += period) {
    // Controller: encoder, model, limits.
    const double xq = q * std::round(xd / q);
    const double model_z = coupled ? force_chain_tool(chain, coupling_only, {0, 0, xq}).z : xq;
    const double f_model = env.tick_force(model_z);
    const bool falling = std::fabs(f_model) < std::fabs(prev_force);
    if (coupled) {
      f_out = run_force_chain(chain, coupling_only, profile, {0, 0, f_model}, {}, env.stiffness(),
                              {0, 0, xq}, period)
                  .force.z;
    } else if (limits == Limits::Limiter || (limits == Limits::RiseOnly && !falling)) {
      SafetyInput in;
      in.force = {0.0, 0.0, f_model};
      in.prev_force = {0.0, 0.0, prev_force};
      in.position = {0.0, 0.0, xq};
      in.prev_position = {0.0, 0.0, prev_pos};
      in.dt = period;
      f_out = apply_device_limits(profile, in).force.z;
    } else {
      f_out = std::clamp(f_model, -profile.max_force_N, profile.max_force_N);
    }
    // Contact as the device feels it (with the coupling, its tool may touch and leave a step
    // in the model while the device's force stays on).
    const double felt = coupled ? f_out : f_model;
    touched = touched || felt > 0.0;
    if (touched && felt == 0.0 && t > kRampS) r.lost_contact = true;
    prev_force = f_out;
    prev_pos = xq;
    if (!measuring && t >= t_measure) {
      measuring = true;
      u_start = potential(xd);
    }
    // Plant: device and hand, force held over the period.
    const double push = push_N * std::min(1.0, t / kRampS);
    for (int s = 0; s < sub; ++s) {
      const double grip = hand.grip_N_per_mm * (xh - xd) + hand.grip_Ns_per_m * (vh - vd) * 1e-3;
      const double fd = f_out + grip - dc.damping_Ns_per_m * vd * 1e-3;
      const double fh = -push - grip - hand.arm_Ns_per_m * vh * 1e-3;
      vd += dt * 1e3 * fd / dc.mass_kg;
      vh += dt * 1e3 * fh / hand.mass_kg;
      const double dx = dt * vd;
      xd += dx;
      xh += dt * vh;
      if (measuring) work += f_out * dx * 1e-3;
    }
    if (t >= t_cycle) {
      cyc_min = std::min(cyc_min, xd);
      cyc_max = std::max(cyc_max, xd);
      depth_sum += env.device_z_for_depth(0.0) - xd;
      ++depth_n;
    }
  }
  const double u_end = potential(xd);
  // Work done on the device minus what a passive rendering of the (clamped) law would return.
  r.inj_mW = (work - (u_start - u_end)) / kMeasureS * 1e3;
  r.p2p_mm = cyc_max - cyc_min;
  r.mean_depth_mm = depth_n ? depth_sum / static_cast<double>(depth_n) : 0.0;
  r.stable = !r.lost_contact && r.p2p_mm < 0.05 + 2.0 * q;
  return r;
}

}  // namespace
}  // namespace palp::study

int main(int argc, char** argv) {
  using namespace palp;
  using namespace palp::study;
  const Flags flags = parse_flags(argc, argv, "study_passivity [--out DIR] [--quick]");
  const double t_start = now_seconds();

  // Scenes: flat skin; flat skin with a bone plate 10 mm under it (a wide, flat "rib").
  const PressScene press = make_press_scene();
  const RibMaps& maps = press.maps;
  const double cx = press.cx, cy = press.cy;
  Environment skin(std::make_shared<const FieldSampler>(maps.surf), maps.skin_level, cx, cy);
  Environment bone(std::make_shared<const FieldSampler>(maps.surf, maps.bone), maps.skin_level, cx,
                   cy);
  std::printf("passivity: skin at z = %.2f, bone plate top %.2f mm under it\n", maps.skin_level,
              maps.skin_level - maps.rib_top);

  const std::vector<double> rates =
      flags.quick ? std::vector<double>{500, 1000, 2000, 10000}
                  : std::vector<double>{500, 750, 1000, 1500, 2000, 3000, 4000, 6000, 8000, 10000};
  const std::vector<double> fractions =
      flags.quick ? std::vector<double>{0.2, 0.5, 0.9}
                  : std::vector<double>{0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9};
  const Hand hand;

  Csv csv(flags.out_dir + "/passivity.csv",
          {"profile", "limits", "scene", "rate_hz", "hand_frac", "hand_N", "depth_eq_mm",
           "stiffness_eq_N_mm", "p2p_mm", "inj_mW", "lost_contact", "stable", "series"});
  Csv boundary(flags.out_dir + "/passivity_boundary.csv",
               {"profile", "limits", "scene", "hand_N", "stiffness_eq_N_mm", "min_stable_rate_hz",
                "series"});
  int runs = 0;
  for (const DeviceClass& dc : kDevices) {
    const DeviceProfile& profile = device_profile(dc.profile);
    for (Limits limits :
         {Limits::Saturation, Limits::Limiter, Limits::RiseOnly, Limits::Coupling}) {
      for (auto* env_ptr : {&skin, &bone}) {
        Environment& env = *env_ptr;
        const char* scene_name = env_ptr == &skin ? "skin" : "bone";
        const std::string series = std::string(scene_name) + ", " + limits_name(limits);
        for (double frac : fractions) {
          const double push = frac * profile.max_force_N;
          double depth_eq = 0.0, k_eq = 0.0;
          env.equilibrium(push, depth_eq, k_eq);
          std::vector<bool> stable;
          for (double rate : rates) {
            const RunResult r = run(env, profile, dc, hand, rate, limits, push);
            ++runs;
            stable.push_back(r.stable);
            csv.row({std::string(dc.profile), limits_name(limits), std::string(scene_name), rate,
                     frac, push, depth_eq, k_eq, r.p2p_mm, r.inj_mW, r.lost_contact ? 1.0 : 0.0,
                     r.stable ? 1.0 : 0.0, series});
          }
          // Lowest rate from which every faster rate is stable; 20 kHz stands for "not even at
          // 10 kHz" so the chart can show it.
          double min_rate = 20000.0;
          for (std::size_t i = rates.size(); i-- > 0;) {
            if (!stable[i]) break;
            min_rate = rates[i];
          }
          boundary.row({std::string(dc.profile), limits_name(limits), std::string(scene_name), push,
                        k_eq, min_rate, series});
          std::printf(
              "  %-15s %-10s %-4s hand %5.2f N (depth %5.2f mm, K %5.2f N/mm): stable "
              "from %s\n",
              dc.profile, limits_name(limits), scene_name, push, depth_eq, k_eq,
              min_rate > 10000.0
                  ? "never (<= 10 kHz)"
                  : (std::to_string(min_rate / 1000.0).substr(0, 4) + " kHz").c_str());
        }
      }
    }
  }
  std::printf("passivity: %d runs, %.1f s, wrote %s, %s\n", runs, now_seconds() - t_start,
              csv.path().c_str(), boundary.path().c_str());
  return 0;
}
