// The pulse in closed loop (issue 39): a hand holds the finger on the skin over a pulsing artery at
// a preload, per device profile, through palpd's chain (palp::run_force_chain: virtual coupling,
// engagement already over, passivity controller, step bound, clamp), and asks whether the force
// limits hold, whether the observer's energy stays bounded, and whether the controller leaves the
// pulse alone, over a minute's hold.
//
// The closed loop is study_stability's (closed_loop.hpp): one degree of freedom along the skin
// normal, the skin law of finger:1 (palp::tick) at the coupling's tool on the encoder-quantised
// position, a device class (mass, damping, encoder) and the hand (mass, grip, arm damping) pushing
// with the preload (ramped in over 0.5 s), integrated at 100 kHz, the workspace's stop 25 mm deep.
// The pulse is a synthetic force source independent of position, A w(phase) along the skin's
// outward normal while the finger touches the skin, at 72 beats a minute: the shape of the
// artery layer's State::f_pulse with its position dependence left out.
//
// Accountings (the chain told the pulse or not):
//   known    the pulse passed as the chain's known active force (palpd with issue 39);
//   unknown  the pulse only inside the model's force (main's chain before issue 39);
//   off      known, with the passivity controller off: the reference for what the controller did.
// Scenarios per profile: preloads 2 N and 5 N (where preload + A fits under the max force) and
// "clamp", the preload at the max force less A / 2 (the beat's top cut by the clamp), each at
// A = 0 (no pulse: the chain's own behaviour on that hold), 0.02, 0.05, 0.1, 0.2 and 0.5 N. Each
// run holds 60 s; "early" is 5 beats from 3 s, "late" the last 5 beats.
//   max_force_N / max_step_N   largest written force and per-tick step over the run, against the
//                              profile's max force and max_force_rate x tick ("limits": both held)
//   active_ratio    peak-to-peak of the pulse's part of the written force over the commanded's,
//                   early (1: the chain passed it whole; known and off only)
//   lift_mm         the pulse as the hand feels it: the device's position averaged over the
//                   window's beats phase by phase (50 bins a beat), peak to peak (the hand pushes
//                   a set force, so the beat lifts the finger; averaging removes what is not
//                   locked to the beat, such as encoder dither); early and late.
//                   lift_expected_mm: A (1/k + 1/K_c), the quasi-static lift on the skin's slope
//                   k at the preload in series with the coupling's K_c. late_vs_off: late lift
//                   against the off run's
//   energy          the observer's energy: its least value from 3 s, its drift per beat from 3 s
//                   to the end, and when it first fell below 0 (nan: never)
//   pc_ticks, pc_mJ the controller's ticks and dissipation from 3 s
// It prints, then, the device table: per profile, the force resolution from what the repository
// cites (the Falcon's from libnifalcon's effort gain through palp's Falcon kinematics; none for
// the others) against the amplitudes. Writes pulse.csv and pulse_devices.csv.
//
//   study_pulse [--out DIR] [--quick]     (--quick: 1 kHz only; default 1 and 10 kHz)
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "bench/closed_loop.hpp"
#include "bench/study_util.hpp"
#include "devices/falcon_kinematics.hpp"
#include "model/structure_layers.hpp"
#include "safety/force_chain.hpp"
#include "safety/safety.hpp"

namespace palp::study {
namespace {

constexpr double kBpm = 72.0, kBeatS = 60.0 / kBpm, kWindowBeats = 5.0;
constexpr double kRampS = 0.5, kFromS = 3.0, kEndS = 60.0;
constexpr double kLateFromS = kEndS - kWindowBeats * kBeatS;
constexpr int kBins = 50;
constexpr double kStopDepthMm = 25.0, kStopNPerMm = 10.0, kStopNsPerM = 20.0;
constexpr double kPi = 3.14159265358979323846;
constexpr double kAmplitudes[] = {0.0, 0.02, 0.05, 0.1, 0.2, 0.5};
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

enum class Accounting { Known, Unknown, Off };
const char* accounting_name(Accounting a) {
  return a == Accounting::Known ? "known" : a == Accounting::Unknown ? "unknown" : "off";
}

struct Scenario {
  std::string name;  // "2N", "5N", "clamp"
  double preload_N, amplitude_N;
};

struct Range {
  double lo = 1e300, hi = -1e300;
  void add(double v) { lo = std::min(lo, v), hi = std::max(hi, v); }
  double p2p() const { return hi >= lo ? hi - lo : kNan; }
};

// One window of beats: the device's position averaged phase by phase, and ranges.
struct Window {
  Window(double from, double to) : from_s(from), to_s(to) {}
  double from_s, to_s;
  std::array<double, kBins> sum{};
  std::array<long, kBins> count{};
  Range commanded, active;
  bool holds(double t) const { return t >= from_s && t < to_s; }
  void add_position(double t, double x) {
    const double phase = t / kBeatS - std::floor(t / kBeatS);
    const auto bin = std::min<std::size_t>(kBins - 1, static_cast<std::size_t>(phase * kBins));
    sum[bin] += x;
    ++count[bin];
  }
  double lift() const {
    Range r;
    for (std::size_t i = 0; i < kBins; ++i)
      if (count[i] > 0) r.add(sum[i] / static_cast<double>(count[i]));
    return r.p2p();
  }
};

struct RunResult {
  double max_force_N = 0.0, max_step_N = 0.0;
  Window early{kFromS, kFromS + kWindowBeats*kBeatS}, late{kLateFromS, kEndS};
  double energy_min = 1e300, energy_from = kNan, energy_end = 0.0, negative_s = kNan;
  long pc_ticks = 0;
  double pc_mJ = 0.0;
};

// The device and the hand (closed_loop.hpp's plant), one integration step with the force held.
struct Plant {
  double xd, vd = 0.0, xh, vh = 0.0;
  void step(double f_out, double push, const DeviceClass& dc, const Hand& hand, double stop_z,
            double dt) {
    const double grip = hand.grip_N_per_mm * (xh - xd) + hand.grip_Ns_per_m * (vh - vd) * 1e-3;
    const double stop = xd < stop_z ? kStopNPerMm * (stop_z - xd) - kStopNsPerM * vd * 1e-3 : 0.0;
    const double fd = f_out + grip + stop - dc.damping_Ns_per_m * vd * 1e-3;
    const double fh = -push - grip - hand.arm_Ns_per_m * vh * 1e-3;
    vd += dt * 1e3 * fd / dc.mass_kg;
    vh += dt * 1e3 * fh / hand.mass_kg;
    xd += dt * vd;
    xh += dt * vh;
  }
};

// The chain's output, one tick, into the result.
void record(RunResult& r, double t, const Vec3d& pulse, const ForceChainOutput& out, Vec3d& prev) {
  r.max_force_N = std::max(r.max_force_N, norm(out.force));
  r.max_step_N = std::max(r.max_step_N, norm(out.force - prev));
  prev = out.force;
  if (r.early.holds(t)) r.early.commanded.add(pulse.z), r.early.active.add(out.active.z);
  if (t < kFromS) return;
  const double e = out.port_energy_mJ;
  r.energy_min = std::min(r.energy_min, e);
  if (std::isnan(r.energy_from)) r.energy_from = e;
  if (e < 0.0 && std::isnan(r.negative_s)) r.negative_s = t;
  r.energy_end = e;
  if (out.damping_N_s_per_mm > 0.0) ++r.pc_ticks, r.pc_mJ += out.dissipated_mJ;
}

RunResult run(Environment& env, const DeviceProfile& profile, const DeviceClass& dc,
              const Hand& hand, double rate, const Scenario& sc, Accounting acc) {
  env.reset_state();
  const double period = 1.0 / rate;
  const int sub = std::max(1, static_cast<int>(std::lround(period / kSimDt)));
  const double stop_z = env.device_z_for_depth(kStopDepthMm);
  Plant plant{env.device_z_for_depth(-0.5), 0.0, env.device_z_for_depth(-0.5), 0.0};
  ForceChainConfig config;
  config.engage = EngageParams{0.2, 1.5};
  config.passivity = acc != Accounting::Off;
  ForceChainState chain;
  chain.engagement = Engagement{false, 1.0};  // the hand meets the chain engaged
  RunResult r;
  Vec3d prev{};
  const long ticks = std::lround(kEndS * rate);
  for (long n = 0; n < ticks; ++n) {
    const double t = static_cast<double>(n) * period;
    const double xq = dc.encoder_mm * std::round(plant.xd / dc.encoder_mm);
    const Vec3d device{env.cx(), 0.0, xq};
    const Vec3d tool = force_chain_tool(chain, config, device);
    const Vec3d skin = env.tick_force_at(tool.x, tool.z);
    const double w = pulse_waveform(t / kBeatS);
    const Vec3d pulse{0.0, 0.0, skin.z > 0.0 ? sc.amplitude_N * w : 0.0};  // felt in contact
    const Vec3d active = acc == Accounting::Unknown ? Vec3d{} : pulse;
    const ForceChainOutput out = run_force_chain(chain, config, profile, skin + pulse, {},
                                                 env.stiffness(), device, period, active);
    record(r, t, pulse, out, prev);
    const double push = sc.preload_N * std::min(1.0, t / kRampS);
    for (int s = 0; s < sub; ++s) {
      plant.step(out.force.z, push, dc, hand, stop_z, period / sub);
      const double ts = t + (s + 1) * period / sub;
      if (r.early.holds(ts)) r.early.add_position(ts, plant.xd);
      if (r.late.holds(ts)) r.late.add_position(ts, plant.xd);
    }
  }
  return r;
}

// The force of one effort count on one Falcon motor at the handle (N), the largest of the three,
// at `p` (Falcon frame, mm): libnifalcon's gain (10 counts per N mm of joint torque,
// falcon::kEffortPerNmm) through palp's kinematics (J^T). Rounding to whole counts leaves at most
// half of each motor's.
double falcon_count_force(const Vec3d& p) {
  double worst = 0.0;
  for (std::size_t i = 0; i < 3; ++i) {
    std::array<std::int16_t, 3> one{};
    one[i] = 1;
    Vec3d f{};
    if (falcon::end_effector_force(p, falcon::torques_from_efforts(one), f))
      worst = std::max(worst, norm(f));
  }
  return worst;
}

struct FalconFigures {
  double count_centre_N = 0.0, count_worst_N = 0.0;  // one count's force
  double reach_2N = 0.0, reach_5N = 0.0;  // share of the cube where 2.5 / 5.5 N along y fit the cap
};
// Over the ±40 mm cube about the centre (9 x 9 x 9 points, as falcon_force_reach).
FalconFigures falcon_figures() {
  FalconFigures ff;
  ff.count_centre_N = falcon_count_force(falcon::kWorkspaceCentre);
  int points = 0, fit2 = 0, fit5 = 0;
  for (int i = 0; i < 9; ++i)
    for (int j = 0; j < 9; ++j)
      for (int k = 0; k < 9; ++k) {
        const double h = falcon::kWorkspaceHalf;
        const Vec3d p =
            falcon::kWorkspaceCentre + Vec3d{-h + i * h / 4, -h + j * h / 4, -h + k * h / 4};
        ff.count_worst_N = std::max(ff.count_worst_N, falcon_count_force(p));
        ++points;
        fit2 += !falcon::efforts_for_force(p, {0, 2.5, 0}).clamped;
        fit5 += !falcon::efforts_for_force(p, {0, 5.5, 0}).clamped;
      }
  ff.reach_2N = static_cast<double>(fit2) / points;
  ff.reach_5N = static_cast<double>(fit5) / points;
  return ff;
}

// The verdict for amplitude A on a device whose one-count force is `step_N` (nan: not known)
// with `headroom` (preload + A under the max force): yes (A drawn in ten steps or more), partly
// (one to ten), no (under one step, or no headroom).
std::string verdict(double amplitude, double step_N, bool headroom) {
  if (!headroom) return "no (max force)";
  if (std::isnan(step_N)) return "not known";
  if (amplitude >= 10.0 * step_N) return "yes";
  return amplitude >= step_N ? "partly" : "no";
}

// What the closed loop showed for one amplitude and preload (1 kHz, known): the early lift over the
// quasi-static one (nan: not run).
struct Shown {
  std::string profile;
  double preload_N, amplitude_N, lift_ratio;
};

// The study's verdict on a lift ratio (the early lift over the quasi-static one): yes within
// 0.75-1.33, partly within 0.5-2, no outside; n/a when not run.
std::string study_verdict(double ratio) {
  if (std::isnan(ratio)) return "n/a";
  if (ratio >= 0.75 && ratio <= 1.0 / 0.75) return "yes";
  return ratio >= 0.5 && ratio <= 2.0 ? "partly" : "no";
}

void device_table(const std::string& out_dir, const std::vector<Shown>& shown) {
  const FalconFigures ff = falcon_figures();
  std::printf(
      "\ndevices: force resolution against the pulse; then the study's verdict on its lift / "
      "expected (1 kHz, known, early)\n");
  std::printf(
      "  falcon: one effort count = %.4f N at the centre, up to %.4f N over the +-40 mm "
      "cube; 2.5 N along y within the effort cap at %.0f %% of it, 5.5 N at %.0f %%\n",
      ff.count_centre_N, ff.count_worst_N, 100 * ff.reach_2N, 100 * ff.reach_5N);
  Csv csv(out_dir + "/pulse_devices.csv",
          {"profile", "max_force_N", "resolution_N", "source", "preload_N", "amp_N", "verdict",
           "study_lift_ratio", "study_verdict"});
  for (const DeviceClass& dc : kDeviceClasses) {
    const DeviceProfile& profile = device_profile(dc.profile);
    const bool falcon = std::string(dc.profile) == "falcon";
    const double step = falcon ? ff.count_worst_N : kNan;
    const std::string source =
        falcon ? "libnifalcon effort gain via falcon_kinematics (worst over the cube)"
               : "none cited (CHAI3D's specifications give no force resolution)";
    for (double preload : {2.0, 5.0}) {
      std::printf("  %-15s %3.0f N:", dc.profile, preload);
      for (double a : kAmplitudes) {
        if (a == 0.0) continue;
        const std::string v = verdict(a, step, preload + a <= profile.max_force_N);
        double ratio = kNan;
        for (const Shown& x : shown)
          if (x.profile == dc.profile && x.preload_N == preload && x.amplitude_N == a)
            ratio = x.lift_ratio;
        const std::string sv = study_verdict(ratio);
        std::printf("  %.2f %s, %s %s;", a, v.c_str(), sv.c_str(), fmt(ratio, "%.3g").c_str());
        csv.row(
            {std::string(dc.profile), profile.max_force_N, step, source, preload, a, v, ratio, sv});
      }
      std::printf("\n");
    }
  }
}

// The scenarios of one profile at amplitude A: 2 N and 5 N where preload + A fits, and the clamp.
std::vector<Scenario> scenarios_for(const DeviceProfile& profile, double a) {
  std::vector<Scenario> out;
  for (double preload : {2.0, 5.0})
    if (preload + a <= profile.max_force_N) out.push_back({fmt(preload, "%g") + "N", preload, a});
  out.push_back({"clamp", profile.max_force_N - a / 2, a});
  return out;
}

struct Row {
  const DeviceClass* dc;
  const DeviceProfile* profile;
  double rate, expected_mm, off_late_mm;
  const Scenario* sc;
  Accounting acc;
};

void write_row(Csv& csv, const Row& w, const RunResult& r) {
  const double bound = w.profile->max_force_rate_N_per_s / w.rate;
  const bool limits =
      r.max_force_N <= w.profile->max_force_N * (1 + 1e-12) && r.max_step_N <= bound * (1 + 1e-9);
  const double commanded = r.early.commanded.p2p();
  const double active_ratio =
      w.acc == Accounting::Unknown || !(commanded > 0.0) ? kNan : r.early.active.p2p() / commanded;
  const double drift = (r.energy_end - r.energy_from) / ((kEndS - kFromS) / kBeatS);
  const double late_vs_off = w.sc->amplitude_N > 0.0 ? r.late.lift() / w.off_late_mm : kNan;
  csv.row({std::string(w.dc->profile),
           w.rate,
           w.sc->name,
           w.sc->preload_N,
           w.sc->amplitude_N,
           accounting_name(w.acc),
           r.max_force_N,
           w.profile->max_force_N,
           r.max_step_N,
           bound,
           limits ? 1.0 : 0.0,
           active_ratio,
           r.early.lift(),
           r.late.lift(),
           w.expected_mm,
           late_vs_off,
           r.energy_min,
           drift,
           r.negative_s,
           static_cast<double>(r.pc_ticks),
           r.pc_mJ});
  std::printf(
      "  %-15s %5.0f %-5s %4.2f %-7s %4.2f %4.2f %6s %7.4f %7.4f %7.4f %6s %8.3f %8.4f %6s %6ld\n",
      w.dc->profile, w.rate, w.sc->name.c_str(), w.sc->amplitude_N, accounting_name(w.acc),
      r.max_force_N / w.profile->max_force_N, r.max_step_N / bound,
      fmt(active_ratio, "%.4f").c_str(), r.early.lift(), r.late.lift(), w.expected_mm,
      fmt(late_vs_off, "%.3f").c_str(), r.energy_min, drift, fmt(r.negative_s, "%.1f").c_str(),
      r.pc_ticks);
}

// Every scenario and accounting of one profile at one rate; returns the number of runs.
int run_profile(Environment& skin, Csv& csv, const DeviceClass& dc, double rate,
                std::vector<Shown>& shown) {
  DeviceProfile profile = device_profile(dc.profile);
  profile.transport_delay_s = 0.0;  // the plant applies each force over the next tick
  const double k_c = coupling_gains(profile, 1.0 / rate).stiffness_N_per_mm;
  const Hand hand;
  int runs = 0;
  for (double a : kAmplitudes) {
    for (const Scenario& sc : scenarios_for(profile, a)) {
      double depth = kNan, k_skin = kNan;
      skin.equilibrium(sc.preload_N, depth, k_skin);
      Row row{&dc, &profile, rate, a * (1.0 / k_skin + 1.0 / k_c), kNan, &sc, Accounting::Off};
      for (Accounting acc : {Accounting::Off, Accounting::Known, Accounting::Unknown}) {
        if (a == 0.0 && acc == Accounting::Unknown) continue;  // no pulse: the same as known
        const RunResult r = run(skin, profile, dc, hand, rate, sc, acc);
        ++runs;
        if (acc == Accounting::Off) row.off_late_mm = r.late.lift();
        if (acc == Accounting::Known && rate == 1000.0 && a > 0.0 && sc.name != "clamp")
          shown.push_back({dc.profile, sc.preload_N, a, r.early.lift() / row.expected_mm});
        row.acc = acc;
        write_row(csv, row, r);
      }
    }
  }
  return runs;
}

}  // namespace
}  // namespace palp::study

int main(int argc, char** argv) {
  using namespace palp;
  using namespace palp::study;
  const Flags flags = parse_flags(argc, argv, "study_pulse [--out DIR] [--quick]");
  const double t_start = now_seconds();
  const PressScene press = make_press_scene();
  Environment skin(std::make_shared<const FieldSampler>(press.maps.surf), press.maps.skin_level,
                   press.cx, press.cy);
  const std::vector<double> rates =
      flags.quick ? std::vector<double>{1000} : std::vector<double>{1000, 10000};
  Csv csv(flags.out_dir + "/pulse.csv",
          {"profile",           "rate_hz",       "scenario",
           "preload_N",         "amp_N",         "accounting",
           "max_force_N",       "force_limit_N", "max_step_N",
           "step_bound_N",      "limits",        "active_ratio",
           "lift_early_mm",     "lift_late_mm",  "lift_expected_mm",
           "late_vs_off",       "energy_min_mJ", "energy_drift_mJ_per_beat",
           "energy_negative_s", "pc_ticks",      "pc_mJ"});
  std::printf(
      "pulse: %.0f bpm, held %.0f s, early = %g beats from %.0f s, late = the last %g; "
      "skin law of finger:1\n",
      kBpm, kEndS, kWindowBeats, kFromS, kWindowBeats);
  std::printf("  %-15s %5s %-5s %4s %-7s %4s %4s %6s %7s %7s %7s %6s %8s %8s %6s %6s\n", "profile",
              "rate", "scen", "A_N", "acct", "f/L", "st/B", "active", "lift_e", "lift_l", "exp_mm",
              "l/off", "E_min", "dE/beat", "E<0_s", "pc");
  int runs = 0;
  std::vector<Shown> shown;
  for (const DeviceClass& dc : kDeviceClasses)
    for (double rate : rates) runs += run_profile(skin, csv, dc, rate, shown);
  device_table(flags.out_dir, shown);
  std::printf("pulse: %d runs, %.1f s, wrote %s and pulse_devices.csv\n", runs,
              now_seconds() - t_start, csv.path().c_str());
  return 0;
}
