// Stability where the printed law fails: a fingertip driven across a thin rib, and a user pushing
// harder than the bone cap.
//
// Scene: a flat skin and one thin rib under it (a bar along y with an elliptic cross-section,
// 8 mm wide and 5 mm thick, its top 8 mm under the skin), voxelised at 1 mm like a CT and turned
// into distance maps by palp::signed_distance. The device is a point mass held by a hand
// (study_util.hpp, HandDevice): the hand pushes down with a set force and drags the device sideways
// through a spring whose set point moves at the commanded speed. The force model runs at the update
// rate (1, 2, 4, 10 kHz) and its force is held between updates while the mass moves (integrated at
// 100 kHz). Offline: no device limits.
//
// 1. Slide: tools finger:1 and finger:37, speeds 20..500 mm/s, indentations 2..12 mm (the push
//    force is the skin law's force at that depth, f_s(d)), with eq. 4 (flip factor 4) and
//    without it (factor 0), printed bone law. Over the rib it records the ticks where the mean
//    bone force points into the body (flips: f_bone . v_s < 0) and where a contact point is
//    inside bone (the bone force vanishes there).
// 2. Push: the hand presses straight down on the rib's crest (guided, one degree of freedom: on
//    a round rib a free finger slips off sideways) with a force ramped from 0 to 100 N, in
//    the printed mode and in the robust mode (ForceParams::bone_mode), at each rate. It records
//    the push force at which a point first ends up inside the rib, the push at which the bone
//    force is lost while the pad is at or past the rib (it vanishes or points inward), how far
//    past the rib's top the pad gets, and whether the finger still oscillates at the end.
// 3. Tunnel: the hand pushes 10..150 N (held, not the skin law's force) while dragging the finger
//    across a round rib 5 or 6 mm across (width = thickness, top 8 mm under the skin) at
//    20..3000 mm/s, at 1 and 4 kHz, for the paper's model (printed and robust bone modes) and
//    the palp model (its precomputed gradient): the ticks with a contact point inside bone
//    (kTickInsideBone) over the whole run, the deepest contact point (State::x, the held point
//    for palp) inside bone, and whether the pad centre got past the rib's bottom.
//
// Writes pop_through_slide.csv (every run), pop_through_thresholds.csv (first indentation with
// a flip / a point inside bone per speed), pop_through_chart.csv (the slide at 100 mm/s as chart
// series), pop_through_speed.csv (12 mm indentation against speed), pop_through_push.csv
// (decimated traces, with the rib's faces as series), pop_through_push_summary.csv and
// pop_through_tunnel.csv (one row per tunnel run).
//
//   study_pop_through [--out DIR] [--quick]
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "bench/study_util.hpp"
#include "model/field_sampler.hpp"
#include "model/force_model.hpp"
#include "model/tool.hpp"

namespace palp::study {
namespace {

constexpr double kRates[] = {1000.0, 2000.0, 4000.0, 10000.0};
constexpr double kSimDt = 1e-5;  // s: the mass is integrated at 100 kHz

// The device and the hand holding it (mm, N, s; masses in kg, dampings in N s/m).
struct HandDevice {
  double mass = 0.25;        // device + hand moving with it
  double damping_z = 5.0;    // hand and device damping along the push
  double damping_xy = 10.0;  // sideways
  double lateral_k = 1.0;    // N/mm: hand's grip spring toward the moving set point
};

struct Body {
  Vec3d x{}, v{};  // mm, mm/s
};

// Advances the body over one update period with the environment force held.
void advance(Body& b, const HandDevice& hd, const Vec3d& f_env, double push_N, double x_set,
             double period) {
  const int n = std::max(1, static_cast<int>(std::lround(period / kSimDt)));
  const double dt = period / n;
  for (int s = 0; s < n; ++s) {
    Vec3d f = f_env;
    f.x += hd.lateral_k * (x_set - b.x.x) - hd.damping_xy * b.v.x * 1e-3;
    f.y += -hd.damping_xy * b.v.y * 1e-3;
    f.z += -push_N - hd.damping_z * b.v.z * 1e-3;
    b.v += (dt * 1e3 / hd.mass) * f;  // N / kg = m/s^2 = 1e3 mm/s^2
    b.x += dt * b.v;
  }
}

// Skin depth at which the skin law alone gives `force` (inverse of f_s, bisection).
double depth_for_force(double force) {
  double lo = 0.0, hi = 100.0;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (surface_force(mid) < force ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

Vec3d mean_bone_force(const State& st) {
  Vec3d sum{};
  int n = 0;
  for (std::size_t i = 0; i < st.f_bone.size(); ++i)
    if (st.in_contact[i]) {
      sum += st.f_bone[i];
      ++n;
    }
  return n > 0 ? sum * (1.0 / n) : Vec3d{};
}

struct SlideResult {
  int window_ticks = 0, inward_ticks = 0, inside_ticks = 0;
  double max_inward_N = 0.0;  // largest inward component of the mean bone force
  bool through = false;       // the pad centre got below the rib's bottom over the rib
  int all_ticks = 0, all_inside_ticks = 0;  // over the whole run, not only the window
  double max_inside_mm = 0.0;  // deepest contact point (State::x) inside bone, D_bone there
};

SlideResult slide(const Model& model, const RibMaps& maps, const RibScene& scene, double rate,
                  double speed, double push_N) {
  const HandDevice hd;
  State st = make_state(model);
  Body b;
  const double x0 = scene.rib_x - 25.0, x1 = scene.rib_x + 25.0;
  b.x = {x0, scene.size_y / 2.0, maps.skin_level + 1.0 - kFingerPadZ};
  const double period = 1.0 / rate;
  const double settle = 0.4;  // s before the set point starts moving
  const double t_end = settle + (x1 - x0) / speed;
  const double half_window = 0.5 * scene.width + 7.5 + 2.0;
  SlideResult r;
  for (double t = 0.0; t < t_end; t += period) {
    tick(model, st, Pose{b.x, Quat{}});
    ++r.all_ticks;
    if (st.status & kTickInsideBone) {
      ++r.all_inside_ticks;
      for (std::size_t i = 0; i < st.x.size(); ++i)
        if (st.in_contact[i])
          r.max_inside_mm = std::max(r.max_inside_mm, model.fields().sample_bone(st.x[i]).value);
    }
    const double x_set = t < settle ? x0 : x0 + speed * (t - settle);
    if (std::fabs(b.x.x - scene.rib_x) < half_window) {
      ++r.window_ticks;
      const Vec3d fb = mean_bone_force(st);
      if (fb.z < -0.01) {
        ++r.inward_ticks;
        r.max_inward_N = std::max(r.max_inward_N, -fb.z);
      }
      if (st.status & kTickInsideBone) ++r.inside_ticks;
      if (std::fabs(b.x.x - scene.rib_x) < 0.5 * scene.width &&
          b.x.z + kFingerPadZ < maps.rib_bottom)
        r.through = true;
    }
    advance(b, hd, st.f_device, push_N, x_set, period);
  }
  return r;
}

struct PushTrace {
  std::vector<double> t, push, depth, f_bone_z;
  double f_inside = std::nan("");   // push force when a point first was inside bone
  double f_lost = std::nan("");     // push force when the bone force first was lost at the rib
  double f_through = std::nan("");  // push force when the pad centre passed the rib's bottom
  double max_depth_below_top = 0.0;
  double hold_p2p = 0.0;   // peak-to-peak pad depth over the final hold (mm): oscillation
  bool left_body = false;  // lost all contact while pushing (an unstable loop threw it out)
};

PushTrace push(const Model& model, const RibMaps& maps, const RibScene& scene, double rate,
               double f_max, double ramp_s) {
  const HandDevice hd;
  State st = make_state(model);
  Body b;
  b.x = {scene.rib_x, scene.size_y / 2.0, maps.skin_level + 1.0 - kFingerPadZ};
  const double period = 1.0 / rate;
  PushTrace tr;
  const double hold = 0.5;
  const double t_end = ramp_s + hold;
  const int decimate = std::max(1, static_cast<int>(std::lround(rate / 200.0)));
  int n = 0;
  bool touched = false;
  double hold_min = 1e300, hold_max = -1e300;
  for (double t = 0.0; t < t_end; t += period, ++n) {
    tick(model, st, Pose{b.x, Quat{}});
    const double push_N = f_max * std::min(1.0, t / ramp_s);
    const double pad_z = b.x.z + kFingerPadZ;
    touched = touched || st.n_contact > 0;
    if (touched && st.n_contact == 0 && push_N > 20.0) tr.left_body = true;
    if ((st.status & kTickInsideBone) && std::isnan(tr.f_inside)) tr.f_inside = push_N;
    if (pad_z <= maps.rib_top && !(mean_bone_force(st).z > 0.0) && std::isnan(tr.f_lost))
      tr.f_lost = push_N;
    if (pad_z < maps.rib_bottom && std::isnan(tr.f_through)) tr.f_through = push_N;
    tr.max_depth_below_top = std::max(tr.max_depth_below_top, maps.rib_top - pad_z);
    if (t > ramp_s + 0.2) {
      hold_min = std::min(hold_min, pad_z);
      hold_max = std::max(hold_max, pad_z);
    }
    if (n % decimate == 0) {
      tr.t.push_back(t);
      tr.push.push_back(push_N);
      tr.depth.push_back(maps.skin_level - pad_z);
      tr.f_bone_z.push_back(mean_bone_force(st).z);
    }
    advance(b, hd, st.f_device, push_N, scene.rib_x, period);
    // The hand guides the finger straight down onto the rib's crest (one degree of freedom):
    // on the round rib it would otherwise slip off sideways into the intercostal space.
    b.x.x = scene.rib_x;
    b.x.y = scene.size_y / 2.0;
    b.v.x = b.v.y = 0.0;
  }
  tr.hold_p2p = hold_max > hold_min ? hold_max - hold_min : 0.0;
  return tr;
}

std::string rate_name(double rate) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g kHz", rate / 1000.0);
  return buf;
}

}  // namespace
}  // namespace palp::study

int main(int argc, char** argv) {
  using namespace palp;
  using namespace palp::study;
  const Flags flags = parse_flags(argc, argv, "study_pop_through [--out DIR] [--quick]");
  const double t_start = now_seconds();

  RibScene scene;
  scene.h = 1.0;
  scene.size_x = 100.0;
  scene.size_y = 40.0;
  scene.size_z = 100.0;
  scene.skin_z = 85.0;
  scene.rib_x = 50.0;
  scene.width = 8.0;
  scene.height = 5.0;
  scene.depth = 7.8;  // the voxelised top face lands 8 mm under the skin, 3 voxels wide
  const RibMaps maps = make_rib_maps(scene);
  auto fields = std::make_shared<const FieldSampler>(maps.surf, maps.bone);
  const double top_depth = maps.skin_level - maps.rib_top;
  const double bottom_depth = maps.skin_level - maps.rib_bottom;
  std::printf(
      "pop_through: rib %g x %g mm at %g mm voxels, top %.2f mm and bottom %.2f mm under "
      "the skin\n",
      scene.width, scene.height, scene.h, top_depth, bottom_depth);

  // ---- 1. Slide across the rib.
  const std::vector<double> speeds =
      flags.quick ? std::vector<double>{100, 500} : std::vector<double>{20, 50, 100, 200, 500};
  const std::vector<double> depths = flags.quick
                                         ? std::vector<double>{4, 10, 12, 14}
                                         : std::vector<double>{2, 4, 6, 8, 10, 11, 12, 13, 14, 16};
  Csv slide_csv(flags.out_dir + "/pop_through_slide.csv",
                {"tool", "rate_hz", "eq4", "speed_mm_s", "indentation_mm", "push_N", "window_ticks",
                 "inward_pct", "inside_pct", "max_inward_N", "through"});
  Csv chart_csv(flags.out_dir + "/pop_through_chart.csv",
                {"tool", "series", "indentation_mm", "pct"});
  Csv speed_csv(flags.out_dir + "/pop_through_speed.csv", {"tool", "series", "speed_mm_s", "pct"});
  Csv thr_csv(
      flags.out_dir + "/pop_through_thresholds.csv",
      {"tool", "rate_hz", "eq4", "series", "speed_mm_s", "first_inward_mm", "first_inside_mm"});
  for (const char* tool_name : {"finger:1", "finger:37"}) {
    for (double flip : {4.0, 0.0}) {
      ForceParams prm = default_params(ToolKind::Finger);
      set_param(prm, "bone_flip", flip);
      const Model model(fields, parse_tool(tool_name), prm);
      for (double rate : kRates) {
        for (double speed : speeds) {
          double first_inward = std::nan(""), first_inside = std::nan("");
          for (double d : depths) {
            const double push_N = surface_force(d);
            const SlideResult r = slide(model, maps, scene, rate, speed, push_N);
            const double inward = r.window_ticks ? 100.0 * r.inward_ticks / r.window_ticks : 0.0;
            const double inside = r.window_ticks ? 100.0 * r.inside_ticks / r.window_ticks : 0.0;
            slide_csv.row({std::string(tool_name), rate, flip == 4.0 ? "yes" : "no", speed, d,
                           push_N, static_cast<double>(r.window_ticks), inward, inside,
                           r.max_inward_N, r.through ? 1.0 : 0.0});
            // Chart series: with eq. 4 the force never points inward, so its failure is the
            // point inside bone (no force); without eq. 4 it is the inward flip.
            const std::string kind =
                flip == 4.0 ? "vanishes (inside bone), eq. 4, " : "flips inward, no eq. 4, ";
            const double pct = flip == 4.0 ? inside : inward;
            if (speed == 100.0)
              chart_csv.row({std::string(tool_name), kind + rate_name(rate), d, pct});
            if (d == 12.0)
              speed_csv.row({std::string(tool_name), kind + rate_name(rate), speed, pct});
            if (r.inward_ticks > 0 && std::isnan(first_inward)) first_inward = d;
            if (r.inside_ticks > 0 && std::isnan(first_inside)) first_inside = d;
          }
          const std::string series = std::string(tool_name) + ", " + rate_name(rate) +
                                     (flip == 4.0 ? ", eq. 4" : ", no eq. 4");
          thr_csv.row({std::string(tool_name), rate, flip == 4.0 ? "yes" : "no", series, speed,
                       first_inward, first_inside});
          std::printf(
              "  slide %-9s %-6s %5.0f mm/s %s: first inward bone force at %s mm, first "
              "point inside bone at %s mm indentation\n",
              tool_name, rate_name(rate).c_str(), speed, flip == 4.0 ? "eq.4   " : "no eq.4",
              std::isnan(first_inward) ? "never"
                                       : std::to_string(first_inward).substr(0, 4).c_str(),
              std::isnan(first_inside) ? "never"
                                       : std::to_string(first_inside).substr(0, 4).c_str());
        }
      }
    }
  }
  std::printf("  slide: %.1f s\n", now_seconds() - t_start);

  // ---- 2. Push harder than the cap.
  Csv push_csv(flags.out_dir + "/pop_through_push.csv",
               {"tool", "mode", "rate_hz", "series", "t_s", "push_N", "depth_mm", "f_bone_z_N",
                "rib_top_mm", "rib_bottom_mm"});
  Csv push_sum(flags.out_dir + "/pop_through_push_summary.csv",
               {"tool", "mode", "rate_hz", "push_inside_N", "push_lost_N", "push_through_N",
                "max_below_top_mm", "hold_p2p_mm", "left_body", "static_inside_N"});
  const double f_max = 100.0, ramp = flags.quick ? 1.5 : 3.0;
  for (const char* tool_name : {"finger:1", "finger:37"}) {
    for (BoneMode mode : {BoneMode::Printed, BoneMode::Robust}) {
      ForceParams prm = default_params(ToolKind::Finger);
      prm.bone_mode = mode;
      const Model model(fields, parse_tool(tool_name), prm);
      for (double rate : kRates) {
        const PushTrace tr = push(model, maps, scene, rate, f_max, ramp);
        if (mode == BoneMode::Printed && rate == kRates[0]) {
          // The rib's faces as two flat series (rate 0) for the chart.
          for (double f : {0.0, f_max}) {
            push_csv.row({std::string(tool_name), "rib", 0.0, "rib top", 0.0, f, top_depth, 0.0,
                          top_depth, bottom_depth});
            push_csv.row({std::string(tool_name), "rib", 0.0, "rib bottom", 0.0, f, bottom_depth,
                          0.0, top_depth, bottom_depth});
          }
        }
        const std::string series = std::string(to_string(mode)) + ", " + rate_name(rate);
        for (std::size_t i = 0; i < tr.t.size(); ++i)
          push_csv.row({std::string(tool_name), std::string(to_string(mode)), rate, series, tr.t[i],
                        tr.push[i], tr.depth[i], tr.f_bone_z[i], top_depth, bottom_depth});
        // Static threshold for finger:1: the skin law at the rib's top plus the cap.
        const double static_inside = surface_force(top_depth) + prm.bone_fmax;
        push_sum.row({std::string(tool_name), std::string(to_string(mode)), rate, tr.f_inside,
                      tr.f_lost, tr.f_through, tr.max_depth_below_top, tr.hold_p2p,
                      tr.left_body ? 1.0 : 0.0, static_inside});
        auto num = [](double v) {
          char buf[32];
          std::snprintf(buf, sizeof buf, "%.1f N", v);
          return std::isnan(v) ? std::string("never") : std::string(buf);
        };
        std::printf(
            "  push  %-9s %-7s %-6s: inside the rib at %s, bone force lost at %s, pad "
            "past the rib's bottom at %s; at most %.2f mm past its top; final "
            "oscillation %.2f mm p-p%s\n",
            tool_name, to_string(mode), rate_name(rate).c_str(), num(tr.f_inside).c_str(),
            num(tr.f_lost).c_str(), num(tr.f_through).c_str(), tr.max_depth_below_top, tr.hold_p2p,
            tr.left_body ? ", THROWN OUT OF CONTACT" : "");
      }
    }
  }
  // ---- 3. Tunnel: 10..150 N across 5-6 mm ribs at 20..3000 mm/s, paper and palp.
  Csv tunnel_csv(flags.out_dir + "/pop_through_tunnel.csv",
                 {"tool", "model", "rib_mm", "rate_hz", "speed_mm_s", "push_N", "ticks",
                  "inside_ticks", "max_inside_mm", "through"});
  const std::vector<double> pushes =
      flags.quick ? std::vector<double>{10, 150} : std::vector<double>{10, 25, 50, 100, 150};
  const std::vector<double> tunnel_speeds =
      flags.quick ? std::vector<double>{20, 3000} : std::vector<double>{20, 100, 300, 1000, 3000};
  struct Variant {
    const char* name;
    ModelKind model;
    BoneMode mode;
  };
  const Variant variants[] = {{"paper printed", ModelKind::Paper, BoneMode::Printed},
                              {"paper robust", ModelKind::Paper, BoneMode::Robust},
                              {"palp", ModelKind::Palp, BoneMode::Robust}};
  for (double rib : {5.0, 6.0}) {
    RibScene ts = scene;
    ts.width = ts.height = rib;
    const RibMaps tmaps = make_rib_maps(ts);
    auto analytic = std::make_shared<const FieldSampler>(tmaps.surf, tmaps.bone);
    auto precomputed = std::make_shared<const FieldSampler>(
        tmaps.surf, tmaps.bone, SamplerConfig{GradientScheme::PrecomputedField, Storage::Float32});
    for (const char* tool_name : {"finger:1", "finger:37"})
      for (const Variant& v : variants) {
        ForceParams prm = model_params(v.model, ToolKind::Finger);
        prm.bone_mode = v.mode;
        const Model model(v.model == ModelKind::Palp ? precomputed : analytic,
                          parse_tool(tool_name), prm);
        for (double rate : {1000.0, 4000.0}) {
          long ticks = 0, inside = 0;
          double deepest = 0.0;
          int runs_inside = 0, runs_through = 0, runs = 0;
          for (double speed : tunnel_speeds)
            for (double push_N : pushes) {
              const SlideResult r = slide(model, tmaps, ts, rate, speed, push_N);
              tunnel_csv.row({std::string(tool_name), std::string(v.name), rib, rate, speed, push_N,
                              static_cast<double>(r.all_ticks),
                              static_cast<double>(r.all_inside_ticks), r.max_inside_mm,
                              r.through ? 1.0 : 0.0});
              ticks += r.all_ticks;
              inside += r.all_inside_ticks;
              deepest = std::max(deepest, r.max_inside_mm);
              runs_inside += r.all_inside_ticks > 0 ? 1 : 0;
              runs_through += r.through ? 1 : 0;
              ++runs;
            }
          std::printf(
              "  tunnel %-9s %-13s rib %g mm %-6s: %ld of %ld ticks with a point inside bone "
              "(%d of %d runs, at most %.2f mm deep), pad past the rib's bottom in %d runs\n",
              tool_name, v.name, rib, rate_name(rate).c_str(), inside, ticks, runs_inside, runs,
              deepest, runs_through);
        }
      }
  }

  std::printf(
      "  static threshold (finger:1): f_s(%.2f) + cap = %.2f + 40 = %.2f N; a push above "
      "it ends inside the rib\n",
      top_depth, surface_force(top_depth), surface_force(top_depth) + 40.0);
  std::printf("  depth for 20 N of skin force alone: %.2f mm\n", depth_for_force(20.0));
  std::printf("pop_through: %.1f s, wrote %s, %s, %s, %s\n", now_seconds() - t_start,
              slide_csv.path().c_str(), thr_csv.path().c_str(), push_csv.path().c_str(),
              push_sum.path().c_str());
  std::printf("pop_through: wrote %s\n", tunnel_csv.path().c_str());
  return 0;
}
