// Stability of palpd's default force chain in closed loop with a hand: the chain of
// HapticLoop::step (virtual coupling, engagement, passivity controller, step bound, clamp) against
// saturation alone, the stiffness limiter alone and the chain before the coupling, per device
// profile, at update rates from 0.5 to 10 kHz.
//
// The closed loop is that of study_passivity (closed_loop.hpp): one degree of freedom along the
// skin normal, a device class (mass, viscous damping, encoder resolution), a hand coupled by the
// grip and pushing with a set force (ramped in over 0.5 s), the force model (finger:1, printed
// bone law, palp::tick) ticked on the quantised position (palpd's chains: at the coupling's
// tool), its force held over the period while both masses move (integrated at 100 kHz). The
// device's workspace ends 25 mm under the skin (a stiff stop, 10 N/mm and 20 N s/m, part of the
// mechanism, not rendered), so a hand the rendered force cannot hold comes to rest there.
//
// Chains (the force written to the device; the declared force is 0, so the profile is unchanged):
//   saturation     clamp to the profile's max force only (the device's own limit);
//   limiter        palp::apply_device_limits (clamp, stiffness limit, rate limit, clamp);
//   palpd-limiter  palp::run_force_chain with the coupling off: the default chain before the
//                  virtual coupling (limiter on its own output, engagement, passivity, step bound);
//   palpd          the default chain: palp::run_force_chain, the function HapticLoop::step calls
//                  (virtual coupling, engagement EngageParams{0.2, 1.5}, the passivity controller
//                  once engaged, step bound, clamp), the model evaluated at the coupling's tool;
//   palpd-engaged  the same chain with its engagement ramp already over when the run starts (as
//                  after 1.5 s in free air), so the hand meets the chain fully engaged.
// A fault zeroes the force and resets as the loop does: model state, engagement, passivity
// state, coupling, previous force 0, previous position the current one.
//
// Scenarios (4 s each):
//   a    skin, hand 50 % of max force
//   b30  skin over a bone plate 10 mm deep, hand 30 % of max
//   b90  the same, hand 90 % of max
//   c    skin, hand 150 % of max (beyond what the device can render)
//   d    skin, hand 50 %; the hand lets go (force 0) for 0.2 s at t = 1.5 s, then pushes again
//   e    skin, hand 50 %; a watchdog fault zeroes the force for 10 ms at t = 1.5 s
//   r    a round rib (6 mm wide, 4 mm high) 8 mm under the skin, pressed on its crest, hand 30 %
//   s    the same rib: the hand presses 15 mm beside it (30 %) and, from t = 1 s, slides across
//        it 30 mm at 30 mm/s and back (the lateral motion prescribed, the friction proxy active),
//        then rests; its energy is the work over the closed slide (1-4 s), negative with friction
//
// Per run (stability.csv):
//   p2p_mm        peak-to-peak device position over the last 0.5 s (3.5-4 s): a sustained cycle
//   ring_p2p_mm   the same over 2.5-3 s (the first version's window: 0.8 s after d's re-press)
//   inj_mJ        energy injected by the rendered environment over 1.5-4 s: the work its force did
//                 on the device plus the change of the potential of the static law clamped to the
//                 max force (with the coupling: the law in series with the coupling's spring) (0
//                 for a passive rendering of that law; nan while palpd holds the force off, where
//                 that law is not what is rendered); energy_resolution_mJ: F_hand q / 2, what
//                 a passive rendering on a q-quantised encoder may read either way
//   max_step_N    largest change of the written force vector from one tick to the next (the fault's
//   own
//                 drop to zero left out), against step_bound_N = max_force_rate * tick
//   engage_s      time from start until the written force first reaches 90 % of the hand force
//                 (of the max force when the hand pushes more; nan: never)
//   fault_step_N  (e) largest per-tick change once the fault has cleared
//   max_depth_mm, end_depth_mm   deepest pad depth under the skin, and its mean over the last
//                 0.5 s; depth_eq_mm: where the rendered static law holds the hand force (nan
//                 beyond the max force; with the coupling, its spring's stretch added); held:
//                 end_depth_mm within 1 mm of that
//   engaged_end   the engagement gain at the end (1 for the other chains)
//   min_force_N   the most negative written force (< 0: the device pulls the pad into the skin)
//   pc_ticks, pc_mJ   ticks on which the passivity controller damped, and what it dissipated
// the worst case per profile (and over all profiles), chain and rate (stability_summary.csv:
// largest p2p and injected energy over a, b30, b90, d, r and s, largest step / bound and the number
// of runs not held over all eight), and traces of the device depth and written force for the touch,
// falcon and phantom-premium at 1 kHz (stability_trace.csv, every 1 ms).
//
//   study_stability [--out DIR] [--quick]     (--quick: 0.5, 1 and 10 kHz only)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "bench/closed_loop.hpp"
#include "bench/study_util.hpp"
#include "safety/engagement.hpp"
#include "safety/force_chain.hpp"
#include "safety/passivity.hpp"
#include "safety/safety.hpp"

namespace palp::study {
namespace {

constexpr double kRampS = 0.5, kEndS = 4.0;
constexpr double kEnergyFromS = 1.5, kRingFromS = 2.5, kRingToS = 3.0, kCycleFromS = 3.5;
constexpr double kEventS = 1.5, kLetGoS = 0.2, kFaultS = 0.010;
constexpr double kStopDepthMm = 25.0, kStopNPerMm = 10.0, kStopNsPerM = 20.0;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

enum class Chain { Saturation, Limiter, PalpdLimiter, Palpd, PalpdEngaged };
const char* chain_name(Chain c) {
  switch (c) {
    case Chain::Saturation:
      return "saturation";
    case Chain::Limiter:
      return "limiter";
    case Chain::PalpdLimiter:
      return "palpd-limiter";
    case Chain::Palpd:
      return "palpd";
    case Chain::PalpdEngaged:
      return "palpd-engaged";
  }
  return "?";
}

enum class Scene { Skin, Plate, RibOn, RibOff };
struct Scenario {
  const char* name;
  const char* what;
  Scene scene;
  double hand_frac;
  bool let_go;  // (d)
  bool fault;   // (e)
  bool slide;   // (s)
};
constexpr Scenario kScenarios[] = {
    {"a", "skin, hand 50%", Scene::Skin, 0.5, false, false, false},
    {"b30", "bone 10 mm deep, hand 30%", Scene::Plate, 0.3, false, false, false},
    {"b90", "bone 10 mm deep, hand 90%", Scene::Plate, 0.9, false, false, false},
    {"c", "skin, hand 150%", Scene::Skin, 1.5, false, false, false},
    {"d", "skin, hand 50%, lets go 0.2 s", Scene::Skin, 0.5, true, false, false},
    {"e", "skin, hand 50%, fault 10 ms", Scene::Skin, 0.5, false, true, false},
    {"r", "on a rib 8 mm deep, hand 30%", Scene::RibOn, 0.3, false, false, false},
    {"s", "slides across a rib and back, hand 30%", Scene::RibOff, 0.3, false, false, true},
};
// (s): from t = 1 s the hand slides 30 mm across the rib at 30 mm/s and back, then rests (1 s).
constexpr double kSlideFromS = 1.0, kSlideMm = 30.0, kSlideMmPerS = 30.0;
double slide_offset(const Scenario& sc, double t) {
  if (!sc.slide || t < kSlideFromS) return 0.0;
  const double s = (t - kSlideFromS) * kSlideMmPerS;
  return s < kSlideMm ? s : std::max(0.0, 2.0 * kSlideMm - s);
}

struct RunResult {
  double p2p_mm = 0.0, inj_mJ = 0.0, max_step_N = 0.0, engage_s = kNan, fault_step_N = kNan;
  double ring_p2p_mm = 0.0;         // peak-to-peak over 2.5-3 s (the window of the first version)
  double coupling_N_per_mm = kNan;  // the virtual coupling's stiffness (coupled chains)
  double max_depth_mm = 0.0, end_depth_mm = 0.0, engaged_end = 1.0;
  long pc_ticks = 0;
  double pc_mJ = 0.0;
  double min_force_N = 0.0;  // most negative written force (pulling the pad into the skin)
};

// Worst case over the scenarios of one profile (or all of them), chain and rate.
struct Worst {
  double p2p_mm = 0.0, inj_mJ = -1e300, step_ratio = 0.0;
  std::string p2p_scenario;
  int not_held = 0, runs = 0;
  void add(const std::string& scenario, const RunResult& r, double ratio, bool held,
           bool cycle_scenario) {
    ++runs;
    if (cycle_scenario && r.p2p_mm > p2p_mm) p2p_mm = r.p2p_mm, p2p_scenario = scenario;
    if (cycle_scenario && !std::isnan(r.inj_mJ)) inj_mJ = std::max(inj_mJ, r.inj_mJ);
    step_ratio = std::max(step_ratio, ratio);
    if (!held) ++not_held;
  }
};

struct TracePoint {
  double t_s, depth_mm, force_N;
};

RunResult run(Environment& env, const DeviceProfile& profile, const DeviceClass& dc,
              const Hand& hand, double rate, Chain chain, const Scenario& sc,
              std::vector<TracePoint>* trace) {
  env.reset_state();
  const double period = 1.0 / rate;
  const int sub = std::max(1, static_cast<int>(std::lround(period / kSimDt)));
  const double dt = period / sub;
  const double push_N = sc.hand_frac * profile.max_force_N;
  const double surface_z = env.device_z_for_depth(0.0);
  const double stop_z = env.device_z_for_depth(kStopDepthMm);
  const EngageParams engage_params{0.2, 1.5};
  const bool coupled = chain == Chain::Palpd || chain == Chain::PalpdEngaged;
  const double k_c = coupling_gains(profile, period).stiffness_N_per_mm;
  // The static law the chain renders: the model's, or with the coupling's spring in series.
  const auto potential = [&](double z) {
    return coupled ? env.coupled_potential(z, k_c, profile.max_force_N)
                   : env.potential(z, profile.max_force_N);
  };
  // Start at rest with the pad 0.5 mm above the skin.
  double xd = env.device_z_for_depth(-0.5), vd = 0.0;
  double xh = xd, vh = 0.0;
  const double q = dc.encoder_mm;
  // The loop's state: what was written last tick, the position then, engagement, passivity.
  Vec3d prev_vec{}, prev_device{env.cx(), 0.0, xd};
  bool prev_valid = false;
  double lat_prev = env.cx();
  // palpd's chains run palp::run_force_chain, the very step HapticLoop::step runs.
  ForceChainConfig chain_config;
  chain_config.engage = engage_params;
  chain_config.passivity = true;
  chain_config.coupling = chain != Chain::PalpdLimiter;
  ForceChainState chain_state;
  if (chain == Chain::PalpdEngaged) chain_state.engagement = Engagement{false, 1.0};

  RunResult r;
  const double engage_target = 0.9 * std::min(push_N, profile.max_force_N);
  double work = 0.0, u_start = 0.0;  // J, over the energy window
  bool measuring = false, faulted = false, after_fault = false;
  double cyc_min = 1e300, cyc_max = -1e300, depth_sum = 0.0;
  double ring_min = 1e300, ring_max = -1e300;
  long depth_n = 0;
  double next_trace = 0.0;
  const long ticks = std::lround(kEndS * rate);
  for (long n = 0; n < ticks; ++n) {
    const double t = static_cast<double>(n) * period;
    const double xq = q * std::round(xd / q);
    // the lateral position (prescribed: the hand leads the device across), quantised too
    const double lat = env.cx() + slide_offset(sc, t);
    const double latq = q * std::round(lat / q);
    const bool fault_now = sc.fault && t >= kEventS && t < kEventS + kFaultS - 1e-9;
    double f_out = 0.0;
    Vec3d f_vec{};
    if (fault_now) {
      // The loop's fault path: zero, then reset everything that carries over.
      env.reset_state();
      reset_force_chain(chain_state);
      chain_state.position_prev = {latq, 0.0, xq};
      chain_state.have_prev = true;
      prev_vec = Vec3d{};
      prev_device = {latq, 0.0, xq};
      prev_valid = true;
      faulted = true;
    } else {
      const bool palpd =
          chain == Chain::Palpd || chain == Chain::PalpdEngaged || chain == Chain::PalpdLimiter;
      // the model at the coupling's tool (palpd's chains) or at the device
      const Vec3d device{latq, 0.0, xq};
      const Vec3d tool = palpd ? force_chain_tool(chain_state, chain_config, device) : device;
      const Vec3d f_model = env.tick_force_at(tool.x, tool.z);
      if (chain == Chain::Saturation) {
        f_vec = clamp_force(f_model, profile.max_force_N).value;
      } else if (!palpd) {
        SafetyInput in;
        in.force = f_model;
        in.prev_force = prev_vec;
        in.position = device;
        in.prev_position = prev_valid ? prev_device : device;
        in.dt = period;
        f_vec = apply_device_limits(profile, in).force;
      } else {
        const ForceChainOutput out = run_force_chain(chain_state, chain_config, profile, f_model,
                                                     {}, env.stiffness(), device, period);
        f_vec = out.force;
        if (out.damping_N_s_per_mm > 0.0) {
          ++r.pc_ticks;
          r.pc_mJ += out.dissipated_mJ;
        }
      }
      f_out = f_vec.z;
      r.min_force_N = std::min(r.min_force_N, f_out);
      const double step = norm(f_vec - prev_vec);
      r.max_step_N = std::max(r.max_step_N, step);
      if (faulted) {
        after_fault = true;
        r.fault_step_N = std::isnan(r.fault_step_N) ? step : std::max(r.fault_step_N, step);
      }
      prev_vec = f_vec;
      prev_device = device;
      prev_valid = true;
    }
    if (std::isnan(r.engage_s) && std::fabs(f_out) >= engage_target) r.engage_s = t;
    // the lateral work of the force over this tick (the hand leads the device across)
    if (measuring) work += f_vec.x * (lat - lat_prev) * 1e-3;
    lat_prev = lat;
    if (!measuring && t >= (sc.slide ? kSlideFromS : kEnergyFromS) - 1e-9) {
      measuring = true;
      u_start = potential(xd);
    }
    // Plant: device and hand, force held over the period.
    double push = push_N * std::min(1.0, t / kRampS);
    if (sc.let_go && t >= kEventS && t < kEventS + kLetGoS - 1e-9) push = 0.0;
    for (int s = 0; s < sub; ++s) {
      const double grip = hand.grip_N_per_mm * (xh - xd) + hand.grip_Ns_per_m * (vh - vd) * 1e-3;
      const double stop = xd < stop_z ? kStopNPerMm * (stop_z - xd) - kStopNsPerM * vd * 1e-3 : 0.0;
      const double fd = f_out + grip + stop - dc.damping_Ns_per_m * vd * 1e-3;
      const double fh = -push - grip - hand.arm_Ns_per_m * vh * 1e-3;
      vd += dt * 1e3 * fd / dc.mass_kg;
      vh += dt * 1e3 * fh / hand.mass_kg;
      const double dx = dt * vd;
      xd += dx;
      xh += dt * vh;
      if (measuring) work += f_out * dx * 1e-3;
      const double ts = t + (s + 1) * dt;
      r.max_depth_mm = std::max(r.max_depth_mm, surface_z - xd);
      if (ts > kRingFromS && ts <= kRingToS) {
        ring_min = std::min(ring_min, xd);
        ring_max = std::max(ring_max, xd);
      }
      if (ts > kCycleFromS) {
        cyc_min = std::min(cyc_min, xd);
        cyc_max = std::max(cyc_max, xd);
        depth_sum += surface_z - xd;
        ++depth_n;
      }
      if (trace && ts >= next_trace - 1e-12) {
        trace->push_back({ts, surface_z - xd, f_out});
        next_trace += 1e-3;
      }
    }
  }
  const double u_end = potential(xd);
  if (coupled) r.coupling_N_per_mm = k_c;
  r.ring_p2p_mm = ring_max - ring_min;
  if (chain == Chain::Palpd || chain == Chain::PalpdEngaged || chain == Chain::PalpdLimiter)
    r.engaged_end = chain_state.engagement.gain;
  // Work done on the device plus what a passive rendering of the (clamped) law would have stored.
  r.inj_mJ = r.engaged_end >= 1.0 ? (work - (u_start - u_end)) * 1e3 : kNan;
  r.p2p_mm = cyc_max - cyc_min;
  r.end_depth_mm = depth_n ? depth_sum / static_cast<double>(depth_n) : 0.0;
  if (sc.fault && !after_fault) r.fault_step_N = 0.0;
  return r;
}

}  // namespace
}  // namespace palp::study

int main(int argc, char** argv) {
  using namespace palp;
  using namespace palp::study;
  const Flags flags = parse_flags(argc, argv, "study_stability [--out DIR] [--quick]");
  const double t_start = now_seconds();

  const PressScene press = make_press_scene();
  const RibMaps& maps = press.maps;
  Environment skin(std::make_shared<const FieldSampler>(maps.surf), maps.skin_level, press.cx,
                   press.cy);
  Environment bone(std::make_shared<const FieldSampler>(maps.surf, maps.bone), maps.skin_level,
                   press.cx, press.cy);
  // A round rib (6 mm wide, 4 mm high, 8 mm under the skin, along y at x = 40): pressed on its
  // crest (r), and slid across from 15 mm beside it (s).
  const RibMaps ribs = make_rib_maps(RibScene{});
  const auto rib_fields = std::make_shared<const FieldSampler>(ribs.surf, ribs.bone);
  Environment rib_on(rib_fields, ribs.skin_level, RibScene{}.rib_x, 20.0);
  Environment rib_off(rib_fields, ribs.skin_level, RibScene{}.rib_x - 15.0, 20.0);
  std::printf("stability: skin at z = %.2f, bone plate top %.2f mm under it, stop at %.0f mm\n",
              maps.skin_level, maps.skin_level - maps.rib_top, kStopDepthMm);

  const std::vector<double> rates = flags.quick ? std::vector<double>{500, 1000, 10000}
                                                : std::vector<double>{500, 1000, 2000, 4000, 10000};
  const Hand hand;

  Csv csv(flags.out_dir + "/stability.csv", {"profile",
                                             "chain",
                                             "scenario",
                                             "what",
                                             "rate_hz",
                                             "hand_frac",
                                             "hand_N",
                                             "p2p_mm",
                                             "inj_mJ",
                                             "max_step_N",
                                             "step_bound_N",
                                             "step_ratio",
                                             "engage_s",
                                             "fault_step_N",
                                             "max_depth_mm",
                                             "end_depth_mm",
                                             "engaged_end",
                                             "pc_ticks",
                                             "pc_mJ",
                                             "depth_eq_mm",
                                             "min_force_N",
                                             "goal_p2p",
                                             "goal_energy",
                                             "goal_step",
                                             "held",
                                             "ring_p2p_mm",
                                             "coupling_N_per_mm",
                                             "energy_resolution_mJ",
                                             "series"});
  Csv trace_csv(flags.out_dir + "/stability_trace.csv",
                {"profile", "chain", "scenario", "rate_hz", "t_s", "depth_mm", "force_N"});
  Csv summary(flags.out_dir + "/stability_summary.csv",
              {"profile", "chain", "rate_hz", "p2p_worst_mm", "p2p_worst_scenario", "inj_worst_mJ",
               "step_ratio_worst", "not_held", "runs"});
  std::map<std::tuple<std::string, std::string, double>, Worst> worst;
  int runs = 0;
  std::printf("  %-15s %-13s %-4s %6s %9s %9s %8s %8s %8s %8s %8s\n", "profile", "chain", "scen",
              "rate", "p2p_mm", "inj_mJ", "step_N", "bound_N", "engage_s", "fault_N", "depth");
  for (const DeviceClass& dc : kDeviceClasses) {
    // The plant here applies each force over the tick after its sample: no transport delay, so
    // the chain is told none (study_delay_release runs delays, told and untold).
    DeviceProfile profile = device_profile(dc.profile);
    profile.transport_delay_s = 0.0;
    for (Chain chain : {Chain::Saturation, Chain::Limiter, Chain::PalpdLimiter, Chain::Palpd,
                        Chain::PalpdEngaged}) {
      for (const Scenario& sc : kScenarios) {
        Environment& env = sc.scene == Scene::Skin    ? skin
                           : sc.scene == Scene::Plate ? bone
                           : sc.scene == Scene::RibOn ? rib_on
                                                      : rib_off;
        for (double rate : rates) {
          const bool traced = rate == 1000.0 && std::string(dc.profile) != "omega";
          std::vector<TracePoint> trace;
          const RunResult r =
              run(env, profile, dc, hand, rate, chain, sc, traced ? &trace : nullptr);
          ++runs;
          const double bound = profile.max_force_rate_N_per_s / rate;
          const double push = sc.hand_frac * profile.max_force_N;
          const bool goal_p2p = r.p2p_mm < 0.1;
          // The energy is read against the static law at the true position while the chain
          // renders it at the encoder's: a passive rendering may read up to F q / 2 (the hand
          // force over half an encoder step) either way. Above that it counts as injected.
          const double energy_resolution = 0.5 * dc.encoder_mm * push * 1.0;  // N mm = mJ
          const bool goal_energy = !(r.inj_mJ > energy_resolution);           // nan (held off): met
          const bool goal_step = r.max_step_N <= bound * (1.0 + 1e-9);
          // The static law's equilibrium for the hand force (none beyond the max force: the
          // device then rests on its stop); "held": the press ends no more than 1 mm deeper.
          double depth_eq = kNan, k_eq = kNan;
          if (push < profile.max_force_N) env.equilibrium(push, depth_eq, k_eq);
          // with the coupling, the device rests deeper than the tool by the spring's stretch
          if (!std::isnan(r.coupling_N_per_mm)) depth_eq += push / r.coupling_N_per_mm;
          const bool held = std::isnan(depth_eq) || std::fabs(r.end_depth_mm - depth_eq) <= 1.0;
          csv.row({std::string(dc.profile),
                   chain_name(chain),
                   std::string(sc.name),
                   std::string(sc.what),
                   rate,
                   sc.hand_frac,
                   push,
                   r.p2p_mm,
                   r.inj_mJ,
                   r.max_step_N,
                   bound,
                   r.max_step_N / bound,
                   r.engage_s,
                   r.fault_step_N,
                   r.max_depth_mm,
                   r.end_depth_mm,
                   r.engaged_end,
                   static_cast<double>(r.pc_ticks),
                   r.pc_mJ,
                   depth_eq,
                   r.min_force_N,
                   goal_p2p ? 1.0 : 0.0,
                   goal_energy ? 1.0 : 0.0,
                   goal_step ? 1.0 : 0.0,
                   held ? 1.0 : 0.0,
                   r.ring_p2p_mm,
                   r.coupling_N_per_mm,
                   energy_resolution,
                   std::string(dc.profile) + ", " + chain_name(chain)});
          // Worst p2p and energy over the presses that should hold (a, b30, b90, d, r, s; s ends
          // at rest where it began, its energy the work over the closed slide); steps and holding
          // over all eight.
          const bool cycle_scenario = sc.name != std::string("c") && sc.name != std::string("e");
          for (const std::string& who : {std::string(dc.profile), std::string("all")})
            worst[{who, chain_name(chain), rate}].add(sc.name, r, r.max_step_N / bound, held,
                                                      cycle_scenario);
          for (const TracePoint& p : trace)
            trace_csv.row({std::string(dc.profile), chain_name(chain), std::string(sc.name), rate,
                           p.t_s, p.depth_mm, p.force_N});
          std::printf("  %-15s %-13s %-4s %6.0f %9.4f %9s %8.3f %8.3f %8s %8s %8.2f\n", dc.profile,
                      chain_name(chain), sc.name, rate, r.p2p_mm, fmt(r.inj_mJ, "%.4f").c_str(),
                      r.max_step_N, bound, fmt(r.engage_s, "%.3f").c_str(),
                      fmt(r.fault_step_N, "%.3f").c_str(), r.max_depth_mm);
        }
      }
    }
  }
  for (const auto& [key, w] : worst)
    summary.row({std::get<0>(key), std::get<1>(key), std::get<2>(key), w.p2p_mm, w.p2p_scenario,
                 w.inj_mJ, w.step_ratio, static_cast<double>(w.not_held),
                 static_cast<double>(w.runs)});
  std::printf("stability: %d runs, %.1f s, wrote %s, %s, %s\n", runs, now_seconds() - t_start,
              csv.path().c_str(), summary.path().c_str(), trace_csv.path().c_str());
  return 0;
}
