// palpd's default force chain in closed loop with a transport delay between the computed and the
// applied force, and with a hand that releases the handle while pressing (docs/stability.md,
// "Delay and release"). The closed loop is that of study_stability (closed_loop.hpp): one degree
// of freedom along the skin normal, a device class, a hand coupled by the grip and pushing with a
// set force (ramped in over 0.5 s), the force model ticked at the coupling's tool on the
// quantised position, the plant integrated at 100 kHz.
//
// Delay: the force palp::run_force_chain computes from the sample read at tick n is applied over
// [n + d, n + d + 1] (d = 0: over the period after the sample, as study_stability does). A USB
// device such as the Falcon exchanges a frame in 1-2 ms, i.e. d = 1-2 at 1 kHz.
//
// Release: at 1.5 s the hand lets go of the handle: its push, its mass and the grip's spring and
// damper are gone; the device is left alone with its own mass and damping, pressed into the
// scene. (study_stability's "lets go" only sets the push to 0 and keeps the hand attached.)
//
// Chains: palpd (run_force_chain as HapticLoop::step runs it: coupling, passivity controller,
// step bound, clamp; engagement already over, as after a ramp in free air), told the delay run
// through the profile's transport_delay_s (its coupling damping widened, its observer lined up);
// palpd-untold (the same with transport_delay_s = 0: the chain before it knew of delays, or a
// device whose delay is not declared); palpd-no-pc (told, the passivity controller off).
//
// Scenarios (4 s each):
//   a      skin, hand 50 % of max force            b30/b90  bone plate 10 mm deep, 30/90 %
//   r      on a rib's crest 8 mm deep, 30 %        b90-rel  b90, the hand lets go at 1.5 s
//   r-rel  r, the hand lets go at 1.5 s
//
// Per run (delay_release.csv):
//   p2p_mm     peak-to-peak device position over 3.5-4 s (for a release: of the device's speed
//              there is no rest; n/a)
//   growth     p2p over 3.5-4 s divided by p2p over 2.5-3 s (> 1: the motion is growing)
//   inj_mJ     the work the applied force did on the device from 1.5 s, plus the change of the
//              potential of the static law the chain renders (the law in series with the
//              coupling's spring, clamped): 0 for a passive rendering, within res_mJ = F q / 2.
//              For a release it is what the device left with beyond what the press had stored.
//   recontacts (release) times the applied force came back on (>= 1 mN) after it had gone
//              below 1 mN; recontact_N the largest force applied after that first drop
//   cycles     hand on: p2p >= 0.1 mm (issue 12's goal); injects: inj_mJ > res_mJ;
//              bounces: recontacts > 0
//
//   study_delay_release [--out DIR] [--quick]     (--quick: 1 kHz only)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "bench/closed_loop.hpp"
#include "bench/study_util.hpp"
#include "safety/force_chain.hpp"
#include "safety/safety.hpp"
#include "safety/virtual_coupling.hpp"

namespace palp::study {
namespace {

constexpr double kRampS = 0.5, kEndS = 4.0, kEventS = 1.5;
constexpr double kRingFromS = 2.5, kRingToS = 3.0, kCycleFromS = 3.5;
constexpr double kStopDepthMm = 25.0, kStopNPerMm = 10.0, kStopNsPerM = 20.0;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kContactN = 1e-3;  // a force below 1 mN is no contact (rounding in free air)

enum class Scene { Skin, Plate, RibOn };
struct Scenario {
  const char* name;
  Scene scene;
  double hand_frac;
  bool release;
};
constexpr Scenario kScenarios[] = {
    {"a", Scene::Skin, 0.5, false},       {"b30", Scene::Plate, 0.3, false},
    {"b90", Scene::Plate, 0.9, false},    {"r", Scene::RibOn, 0.3, false},
    {"b90-rel", Scene::Plate, 0.9, true}, {"r-rel", Scene::RibOn, 0.3, true},
};

struct Variant {
  const char* name;
  bool passivity;
  bool told;  // the profile's transport_delay_s is the delay run (else 0: the chain not told)
};
constexpr Variant kVariants[] = {
    {"palpd", true, true}, {"palpd-untold", true, false}, {"palpd-no-pc", false, true}};

struct RunResult {
  double p2p_mm = kNan, growth = kNan, inj_mJ = 0.0, res_mJ = 0.0;
  int recontacts = 0;
  double recontact_N = 0.0;  // the largest force applied after the first drop below 1 mN
  long pc_ticks = 0;
  bool cycles = false, injects = false, bounces = false;
  bool bad() const { return cycles || injects || bounces; }
};

struct Window {
  double lo = 1e300, hi = -1e300;
  void add(double x) { lo = std::min(lo, x), hi = std::max(hi, x); }
  double p2p() const { return hi >= lo ? hi - lo : 0.0; }
};

struct Plant {
  double xd, vd, xh, vh;
};

// One plant step of length dt with the applied force f (N) held: the device, and the hand unless
// it has let go. Returns the device's travel (mm).
double plant_step(Plant& p, const DeviceClass& dc, const Hand& hand, double f, double push,
                  bool released, double stop_z, double dt) {
  const double stop =
      p.xd < stop_z ? kStopNPerMm * (stop_z - p.xd) - kStopNsPerM * p.vd * 1e-3 : 0.0;
  const double grip =
      released ? 0.0
               : hand.grip_N_per_mm * (p.xh - p.xd) + hand.grip_Ns_per_m * (p.vh - p.vd) * 1e-3;
  const double fd = f + grip + stop - dc.damping_Ns_per_m * p.vd * 1e-3;
  p.vd += dt * 1e3 * fd / dc.mass_kg;
  if (!released) {
    const double fh = -push - grip - hand.arm_Ns_per_m * p.vh * 1e-3;
    p.vh += dt * 1e3 * fh / hand.mass_kg;
    p.xh += dt * p.vh;
  }
  const double dx = dt * p.vd;
  p.xd += dx;
  return dx;
}

RunResult run(Environment& env, const DeviceProfile& class_profile, const DeviceClass& dc,
              const Hand& hand, double rate, int delay, const Variant& variant,
              const Scenario& sc) {
  env.reset_state();
  const double period = 1.0 / rate;
  DeviceProfile profile = class_profile;
  profile.transport_delay_s = variant.told ? delay * period : 0.0;
  const int sub = std::max(1, static_cast<int>(std::lround(period / kSimDt)));
  const double dt = period / sub, q = dc.encoder_mm;
  const double push_N = sc.hand_frac * profile.max_force_N;
  const double stop_z = env.device_z_for_depth(kStopDepthMm);
  const double k_c = coupling_gains(profile, period).stiffness_N_per_mm;
  const auto potential = [&](double z) {
    return env.coupled_potential(z, k_c, profile.max_force_N);
  };
  ForceChainConfig config;
  config.engage = EngageParams{0.2, 1.5};
  config.passivity = variant.passivity;
  ForceChainState chain;
  chain.engagement = Engagement{false, 1.0};  // the ramp is over (as after 1.5 s in free air)
  std::deque<double> in_flight(static_cast<std::size_t>(delay), 0.0);  // computed, not applied

  Plant p{env.device_z_for_depth(-0.5), 0.0, 0.0, 0.0};
  p.xh = p.xd;
  RunResult r;
  double work = 0.0, u_start = 0.0;
  bool measuring = false, off_since_release = false, gone = false;
  Window ring, cycle;
  const long ticks = std::lround(kEndS * rate);
  for (long n = 0; n < ticks; ++n) {
    const double t = static_cast<double>(n) * period;
    const Vec3d device{env.cx(), 0.0, q * std::round(p.xd / q)};
    const double tool_z = force_chain_tool(chain, config, device).z;
    const double f_model = env.tick_force(tool_z);
    const ForceChainOutput out = run_force_chain(chain, config, profile, {0, 0, f_model}, {},
                                                 env.stiffness(), device, period);
    if (out.damping_N_s_per_mm > 0.0) ++r.pc_ticks;
    in_flight.push_back(out.force.z);
    const double applied = in_flight.front();
    in_flight.pop_front();
    const bool released = sc.release && t >= kEventS - 1e-9;
    if (released) {
      if (applied < kContactN)
        off_since_release = gone = true;
      else if (off_since_release)
        ++r.recontacts, off_since_release = false;
      if (gone) r.recontact_N = std::max(r.recontact_N, applied);
    }
    if (!measuring && t >= kEventS - 1e-9) measuring = true, u_start = potential(p.xd);
    const double push = push_N * std::min(1.0, t / kRampS);
    for (int s = 0; s < sub; ++s) {
      const double dx = plant_step(p, dc, hand, applied, push, released, stop_z, dt);
      if (measuring) work += applied * dx * 1e-3;
      const double ts = t + (s + 1) * dt;
      if (ts > kRingFromS && ts <= kRingToS) ring.add(p.xd);
      if (ts > kCycleFromS) cycle.add(p.xd);
    }
  }
  r.inj_mJ = (work - (u_start - potential(p.xd))) * 1e3;
  r.res_mJ = 0.5 * q * push_N;
  r.injects = r.inj_mJ > r.res_mJ;
  if (!sc.release) {
    r.p2p_mm = cycle.p2p();
    r.growth = ring.p2p() > 0.0 ? r.p2p_mm / ring.p2p() : kNan;
    r.cycles = r.p2p_mm >= 0.1;
  }
  r.bounces = r.recontacts > 0;
  return r;
}

}  // namespace
}  // namespace palp::study

int main(int argc, char** argv) {
  using namespace palp;
  using namespace palp::study;
  const Flags flags = parse_flags(argc, argv, "study_delay_release [--out DIR] [--quick]");
  const double t_start = now_seconds();
  const PressScene press = make_press_scene();
  Environment skin(std::make_shared<const FieldSampler>(press.maps.surf), press.maps.skin_level,
                   press.cx, press.cy);
  Environment bone(std::make_shared<const FieldSampler>(press.maps.surf, press.maps.bone),
                   press.maps.skin_level, press.cx, press.cy);
  const RibMaps ribs = make_rib_maps(RibScene{});
  Environment rib_on(std::make_shared<const FieldSampler>(ribs.surf, ribs.bone), ribs.skin_level,
                     RibScene{}.rib_x, 20.0);
  const std::vector<double> rates =
      flags.quick ? std::vector<double>{1000} : std::vector<double>{500, 1000, 2000, 4000, 10000};
  const Hand hand;
  Csv csv(flags.out_dir + "/delay_release.csv",
          {"profile", "chain", "scenario", "rate_hz", "delay_ticks", "p2p_mm", "growth", "inj_mJ",
           "res_mJ", "recontacts", "recontact_N", "pc_ticks", "cycles", "injects", "bounces"});
  int runs = 0;
  for (const Variant& variant : kVariants) {
    std::printf("\n%s: what cycles (p2p >= 0.1 mm), injects (> F q / 2) or bounces, per delay\n",
                variant.name);
    std::printf("| profile | rate | d = 0 | d = 1 | d = 2 | d = 3 |\n|---|---|---|---|---|---|\n");
    for (const DeviceClass& dc : kDeviceClasses) {
      const DeviceProfile& profile = device_profile(dc.profile);
      for (double rate : rates) {
        std::printf("| %s | %g kHz |", dc.profile, rate / 1000.0);
        for (int delay = 0; delay <= 3; ++delay) {
          std::string bad;
          for (const Scenario& sc : kScenarios) {
            Environment& env = sc.scene == Scene::Skin    ? skin
                               : sc.scene == Scene::Plate ? bone
                                                          : rib_on;
            const RunResult r = run(env, profile, dc, hand, rate, delay, variant, sc);
            ++runs;
            csv.row({std::string(dc.profile), std::string(variant.name), std::string(sc.name), rate,
                     static_cast<double>(delay), r.p2p_mm, r.growth, r.inj_mJ, r.res_mJ,
                     static_cast<double>(r.recontacts), r.recontact_N,
                     static_cast<double>(r.pc_ticks), r.cycles ? 1.0 : 0.0, r.injects ? 1.0 : 0.0,
                     r.bounces ? 1.0 : 0.0});
            if (!r.bad()) continue;
            // the scenario and its worst figure: the cycle's p2p, else the energy, else bounces
            bad += (bad.empty() ? " " : ", ") + std::string(sc.name) + " ";
            if (r.cycles)
              bad += fmt(r.p2p_mm, "%.2g mm");
            else if (r.injects)
              bad += fmt(r.inj_mJ, "+%.2g mJ");
            else
              bad += std::to_string(r.recontacts) + "x " + fmt(r.recontact_N, "%.2g N");
          }
          std::printf("%s |", bad.empty() ? " —" : bad.c_str());
        }
        std::printf("\n");
      }
    }
  }
  std::printf("\ndelay_release: %d runs, %.1f s, wrote %s\n", runs, now_seconds() - t_start,
              csv.path().c_str());
  return 0;
}
