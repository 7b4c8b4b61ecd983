// The palp force model measured beside the paper's (issue 14, docs/force_model.md "The palp
// model"). Each model runs on the sampler its commands use: paper with the analytic trilinear
// gradient, palp with the precomputed field. Kinematic: the device follows the path exactly.
//
// 1. Contrast  ribs against intercostal spaces at equal skin depth. Paths of `palp traj ribs`
//    (ribs_body_axis / ribs_skin_frame): the torso's right side at 0, 15, 30 and 45 deg anterior
//    of lateral over 0.25-0.75 of the body axis; the real CT every 10 deg from -50 to 20 deg over
//    0.55-0.99 (its ribs lie in the top part), each scanned every 0.5 mm. A rib crest is a local
//    minimum (within +-6 mm) of the distance from the skin point along -n to bone (within 40 mm),
//    an intercostal space the farthest point between two crests of a path (no bone within 40 mm
//    counts as farthest), kept only when it lies 5 mm deeper than both crests (else the two are
//    one bony surface). At each site the tool (finger:1, finger:37) is pressed along the skin
//    normal from 2 mm above the skin to a pad depth of 2..12 mm (0.5 s at 1 kHz) and held 0.1 s;
//    the pressing force is f_device . n over the last 50 ticks, also with the bone off (CSV).
//    Ratio: every crest against each neighbouring space; median and smallest over all paths. Beside
//    palp's own set (reach 9 mm), palp measured with the bone law reaching 5 (printed), 6, 8 and
//    10 mm. The cost of the reach: the bone's share of the pressing force (force - skin-only
//    force) at the crests and at the sites with no bone within 20 mm beneath the skin point.
// 2. Friction  flat skin (1 mm voxels, bone off), finger:1 at 1 kHz unless said: a slide at 4 mm
//    at 100..800 mm/s (mean lateral force over the second half of 40 mm); the same at 200 and
//    800 mm/s at 1..10 kHz; press to 1..8 mm, shift sideways by half the model's breakaway
//    distance (paper c f_s, palp mu f_n / k), hold 5 s with +-0.05 mm uniform jitter on both
//    tangent axes: decay of the lateral force from the hold's first 0.5 s to its last; and over
//    every tick of all of these the largest |f_friction| / (mu f_n) per point (mu = 0.5 for both).
// 3. Smoothness  the real CT, bone off, finger:1 slid at 20 mm/s (1 kHz) along the anterior
//    abdomen (azimuth 90 deg, 0.30-0.60 of the body axis) at a constant true depth (2, 4, 6 mm)
//    below the -500 HU iso-surface of the trilinearly interpolated CT: the pad on the ray of the
//    ribs frame where its global distance to the skin's iso-surface (study_skin.hpp, checked
//    against a brute-force sampling of the surface) equals the depth: |f_device| detrended by a
//    centred 10 mm moving average, its standard deviation and the largest change between two
//    ticks; the path's own exact depth (detrended std) and largest step in position.
//
// 4. Contact count  a skin ball (R 30 mm): finger:1/7/19/37 pressed along the radius to
//    2..8 mm, the pressing force against finger:1's (the paper claims independence of the count).
//
// Writes force_model_contrast.csv, force_model_contrast_ratio.csv, force_model_bone_cost.csv,
// force_model_friction.csv, force_model_creep.csv, force_model_contacts.csv and
// force_model_smooth.csv. Skips the CT parts when the file is absent.
//
//   study_force_model [--out DIR] [--quick]
// PALP_CT: the CT (default ../shared/data/ct_abdomen_3mm.nii.gz).
// PALP_MAP_SPACING: prep's --map-spacing for the CT (0: the CT's own grid; default prep's).
// PALP_MEMORY_MAP_SPACING: the palp model's maps refined in memory to at most this spacing
// (scene/scene_maps.hpp; default kPalpMapSpacingMm, as palp run's; 0: as prepped). The paper's
// maps are never refined (its --map-spacing default is 0).
// PALP_SMOOTH_PATH: the smoothness path: global (default, above); normal: the pad `depth` along
// the HU normal at the skin point (central differences over 1.5 mm; the earlier path, whose exact
// depth wanders); exact: that, then moved along the normal onto prep's single descent's distance
// (which jumps where its closest point switches sheets).
// PALP_SMOOTH_POSE=ray: the pad oriented by the ray instead of the HU normal at the skin point.
// PALP_SMOOTH_TRAJ_DIR: also write the smoothness path at each depth as a trajectory CSV,
// DIR/skin_path_<depth>mm.csv (the paper variant's; `palp run --trajectory` replays it:
// tests/bench/skin_ripple_methods.sh).
// PALP_STUDY_PARTS: the parts to run (names among contrast, friction, contacts, smooth; all
// when unset).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "base/errors.hpp"
#include "bench/study_skin.hpp"
#include "bench/study_util.hpp"
#include "io/ct_io.hpp"
#include "model/field_sampler.hpp"
#include "model/force_model.hpp"
#include "model/tool.hpp"
#include "prep/maps/iso_projection.hpp"
#include "prep/maps/map_refine.hpp"
#include "scene/scene.hpp"
#include "scene/trajectory.hpp"
#include "scene/trajectory_gen.hpp"

namespace palp::study {
namespace {

struct Variant {
  ModelKind model;
  std::shared_ptr<const FieldSampler> fields;
};

std::shared_ptr<const FieldSampler> load_fields(const std::string& scene, ModelKind model,
                                                GradientScheme g) {
  SceneOptions options;
  options.sampler.gradient = g;
  if (model == ModelKind::Palp) {
    options.map_spacing_mm = kPalpMapSpacingMm;
    if (const char* spacing = std::getenv("PALP_MEMORY_MAP_SPACING"))
      options.map_spacing_mm = std::strtod(spacing, nullptr);
  }
  // PALP_MAP_SPACING: prep's --map-spacing for a CT scene (default its default).
  if (const char* spacing = std::getenv("PALP_MAP_SPACING"))
    options.prep.map_spacing_mm = std::strtod(spacing, nullptr);
  return load_scene(scene, options).fields;
}

std::vector<Variant> variants_for(const std::string& scene) {
  return {
      {ModelKind::Paper, load_fields(scene, ModelKind::Paper, GradientScheme::AnalyticTrilinear)},
      {ModelKind::Palp, load_fields(scene, ModelKind::Palp, GradientScheme::PrecomputedField)}};
}

// Distance along dir from `from` to the first sample inside bone, NaN within `length` none.
double ray_to_bone(const FieldSampler& f, const Vec3d& from, const Vec3d& dir, double length) {
  const double step = 0.25 * f.grid().min_spacing();
  for (double s = 0.0; s <= length; s += step) {
    const FieldSample b = f.sample_bone(from + dir * s);
    if (b.inside && b.value >= 0.0) return s;
  }
  return std::nan("");
}

// ---- 1. Contrast -------------------------------------------------------------------------------

struct Site {
  double along = 0.0, pos_mm = 0.0, below = 0.0;
  bool rib = false;
  SkinFrame frame;
};

// mm: a site with no bone within this beneath its skin point counts as far from bone.
constexpr double kFarFromBone = 20.0;

// Rib crests and intercostal spaces along the ribs path, in path order.
std::vector<Site> find_sites(const FieldSampler& f, const RibsSpec& spec, const BodyAxis& axis) {
  constexpr double kRay = 40.0;
  constexpr double kProminence = 5.0;  // mm: half a rib's height
  std::vector<Site> prof;
  const double step = 0.5 / axis.extent;
  for (double a = spec.from; a <= spec.to; a += step) {
    Site s;
    s.along = a;
    s.pos_mm = (a - spec.from) * axis.extent;
    try {
      s.frame = ribs_skin_frame(f, axis, a);
    } catch (const InputError&) {
      continue;
    }
    const double b = ray_to_bone(f, s.frame.skin, -1.0 * s.frame.normal, kRay);
    s.below = std::isnan(b) ? kRay + 1.0 : b;
    prof.push_back(s);
  }
  std::vector<std::size_t> crests;
  const std::size_t w = 12;  // +-6 mm
  for (std::size_t i = w; i + w < prof.size(); ++i) {
    if (!(prof[i].below <= kRay)) continue;
    bool min = true;
    for (std::size_t j = i - w; j <= i + w && min; ++j)
      if (prof[j].below < prof[i].below || (j < i && prof[j].below == prof[i].below)) min = false;
    if (min) crests.push_back(i);
  }
  std::vector<Site> out;
  for (std::size_t c = 0; c < crests.size(); ++c) {
    Site r = prof[crests[c]];
    r.rib = true;
    out.push_back(r);
    if (c + 1 == crests.size()) break;
    // The farthest point between two crests (the middle of a run of equals).
    std::size_t best = crests[c] + 1, best_end = best;
    for (std::size_t j = crests[c] + 1; j < crests[c + 1]; ++j) {
      if (prof[j].below > prof[best].below) best = best_end = j;
      if (prof[j].below == prof[best].below) best_end = j;
    }
    // A space lies kProminence deeper than the crests either side (or over no bone within the
    // ray); else the two crests are one bony surface (a rib seen obliquely, two ribs touching)
    // and what lies between them is no space.
    const Site& space = prof[(best + best_end) / 2];
    if (space.below >= std::max(prof[crests[c]].below, prof[crests[c + 1]].below) + kProminence)
      out.push_back(space);
  }
  return out;
}

// Pressing force (f_device . n, mean over the last 50 ticks) after a 0.5 s press to `depth`.
double press_force(const Model& model, State& st, const SkinFrame& frame, double depth,
                   double offset) {
  reset(st);
  const FieldSampler& f = model.fields();
  const Quat q = surface_orientation(frame.normal, frame.slide);
  const Vec3d end = pad_centre_at_depth(f, frame, depth);
  const Vec3d start = frame.skin + 2.0 * frame.normal;
  constexpr int kPress = 500, kHold = 100, kAvg = 50;
  double sum = 0.0;
  for (int t = 0; t <= kPress + kHold; ++t) {
    const double u = std::min(1.0, static_cast<double>(t) / kPress);
    tick(model, st, pad_pose(start + u * (end - start), frame.normal, q, offset));
    if (t > kPress + kHold - kAvg) sum += dot(st.f_device, frame.normal);
  }
  return sum / kAvg;
}

void contrast(const std::string& scene_name, const std::string& scene,
              const std::vector<RibsSpec>& specs, const std::vector<double>& depths, Csv& csv,
              Csv& ratio_csv, Csv& cost_csv) {
  const std::vector<Variant> vars = variants_for(scene);
  // Sites per path (ratios only within a path).
  std::vector<std::vector<Site>> paths;
  for (const RibsSpec& spec : specs) {
    const BodyAxis axis = ribs_body_axis(*vars[0].fields, spec);
    paths.push_back(find_sites(*vars[0].fields, spec, axis));
    int n_rib = 0;
    for (const Site& s : paths.back()) n_rib += s.rib ? 1 : 0;
    std::printf(
        "contrast %s azimuth %g, %g-%g: %d rib crests, %d intercostal spaces:", scene_name.c_str(),
        spec.azimuth_deg, spec.from, spec.to, n_rib, static_cast<int>(paths.back().size()) - n_rib);
    for (const Site& s : paths.back())
      std::printf(" %s%.1f(%.1f)", s.rib ? "R" : "i", s.pos_mm, s.below);
    std::printf("  [position mm (bone below the skin, mm)]\n");
  }
  for (const char* tool_name : {"finger:1", "finger:37"}) {
    const Tool tool = parse_tool(tool_name);
    const double offset = pad_offset(tool);
    // Each model's own set; beside palp's, palp measured with one parameter changed.
    struct Series {
      const Variant* v;
      ForceParams prm;
      std::string name, model;
    };
    std::vector<Series> series;
    for (const Variant& v : vars) {
      const ForceParams prm = model_params(v.model, tool.kind);
      series.push_back(
          {&v, prm, std::string(to_string(v.model)) + ", " + tool_name, to_string(v.model)});
      if (v.model != ModelKind::Palp) continue;
      for (double r : {5.0, 6.0, 8.0, 10.0}) {
        ForceParams reach = prm;
        reach.bone_reach_mm = r;
        char name[96];
        std::snprintf(name, sizeof name, "palp, bone reach %g mm, %s", r, tool_name);
        series.push_back({&v, reach, name, "palp variant"});
      }
    }
    // The skin-only force does not depend on the bone's reach: palp's is kept for its variants.
    std::vector<double> palp_skin;
    for (const Series& se : series) {
      ForceParams skin_only = se.prm;
      skin_only.bone_enabled = false;
      const Model model(se.v->fields, tool, se.prm), skin_model(se.v->fields, tool, skin_only);
      State st = make_state(model), st_skin = make_state(skin_model);
      const bool variant = se.model == "palp variant";
      std::size_t skin_i = 0;
      std::vector<std::string> cost_lines;
      std::printf("  %-46s", se.name.c_str());
      for (double d : depths) {
        std::vector<double> ratios, bone_crest, bone_far;
        for (std::size_t pi = 0; pi < paths.size(); ++pi) {
          const std::vector<Site>& sites = paths[pi];
          std::vector<double> force;
          for (const Site& s : sites) {
            force.push_back(press_force(model, st, s.frame, d, offset));
            double skin = 0.0;
            if (variant) {
              skin = palp_skin.at(skin_i++);
            } else {
              skin = press_force(skin_model, st_skin, s.frame, d, offset);
              if (se.model == "palp") palp_skin.push_back(skin);
              csv.row({scene_name, std::string(tool_name), se.model, specs[pi].azimuth_deg, d,
                       s.rib ? "rib" : "intercostal", s.pos_mm, s.below, force.back(), skin});
            }
            // The bone's share of the pressing force, at crests and where no bone lies within
            // kFarFromBone beneath the skin point (what a longer reach costs).
            if (s.rib) bone_crest.push_back(force.back() - skin);
            if (s.below > kFarFromBone) bone_far.push_back(force.back() - skin);
          }
          for (std::size_t i = 0; i < sites.size(); ++i) {
            if (sites[i].rib) continue;
            if (i > 0 && sites[i - 1].rib) ratios.push_back(force[i - 1] / force[i]);
            if (i + 1 < sites.size() && sites[i + 1].rib) ratios.push_back(force[i + 1] / force[i]);
          }
        }
        const double med = median(ratios), lo = percentile(ratios, 0.0);
        ratio_csv.row({scene_name, std::string(tool_name), se.model, se.name, d, med, lo,
                       static_cast<double>(ratios.size())});
        std::printf(" %g:%.2f(%.2f)", d, med, lo);
        const double far_med = median(bone_far), far_max = percentile(bone_far, 1.0);
        const double crest_med = median(bone_crest);  // NaN where none
        const double reach =
            se.prm.model == ModelKind::Palp ? se.prm.bone_reach_mm : std::nan("");  // paper: none
        cost_csv.row({scene_name, std::string(tool_name), se.name, reach, d, crest_med,
                      static_cast<double>(bone_crest.size()), far_med, far_max,
                      static_cast<double>(bone_far.size())});
        char line[160];
        std::snprintf(line, sizeof line, " %g:%.2f/%.2f(%.2f)", d, crest_med, far_med, far_max);
        cost_lines.emplace_back(line);
      }
      std::printf("   [depth mm: median (smallest) rib / space, %zu pairs]\n", [&] {
        std::size_t n = 0;
        for (const auto& sites : paths)
          for (std::size_t i = 0; i < sites.size(); ++i)
            if (!sites[i].rib)
              n += (i > 0 && sites[i - 1].rib) + (i + 1 < sites.size() && sites[i + 1].rib);
        return n;
      }());
      std::printf("  bone N %-39s", se.name.c_str());
      for (const std::string& l : cost_lines) std::printf("%s", l.c_str());
      std::printf(
          "   [depth mm: bone share of the pressing force, median at crests / median "
          "(largest) where no bone lies within %g mm beneath]\n",
          kFarFromBone);
    }
  }
}

// ---- 2. Friction on flat skin ------------------------------------------------------------------

struct FlatScene {
  RibMaps maps;
  std::vector<Variant> vars;
  double skin = 0.0;  // z of the skin plane
  double mid_y = 0.0;
};

FlatScene flat_scene() {
  RibScene s;
  s.h = 1.0;
  s.size_x = 120.0;
  s.size_y = 40.0;
  s.size_z = 50.0;
  s.skin_z = 35.0;
  s.depth = 30.0;  // the rib, unused (bone off)
  FlatScene fs;
  fs.maps = make_rib_maps(s);
  fs.vars = {
      {ModelKind::Paper, std::make_shared<const FieldSampler>(fs.maps.surf, fs.maps.bone)},
      {ModelKind::Palp, std::make_shared<const FieldSampler>(
                            fs.maps.surf, fs.maps.bone,
                            SamplerConfig{GradientScheme::PrecomputedField, Storage::Float32})}};
  fs.skin = fs.maps.skin_level;
  fs.mid_y = s.size_y / 2.0;
  return fs;
}

// Over the points in contact: the largest |f_friction| / f_n (f_n the pressing force, bone off)
// where f_n > 1e-6 N, and how many points carry friction (> 1e-6 N) with no pressing force.
struct Bound {
  double mu_max = 0.0;
  long no_press = 0;
};
void friction_bound(const State& st, Bound& b) {
  for (std::size_t i = 0; i < st.f.size(); ++i) {
    if (!st.in_contact[i]) continue;
    const double fn = (st.f[i] - st.f_friction[i]).z;  // flat skin: the normal is +z
    const double fr = norm(st.f_friction[i]);
    if (fn > 1e-6)
      b.mu_max = std::max(b.mu_max, fr / fn);
    else if (fr > 1e-6)
      ++b.no_press;
  }
}

// Mean lateral friction (N, against +x) over the second half of a 40 mm slide at `depth`.
double slide_friction(const Model& m, const FlatScene& fs, double depth, double speed, double rate,
                      Bound& bound) {
  State st = make_state(m);
  const double period = 1.0 / rate, press_s = 0.3, len = 40.0;
  const double x0 = 30.0, pad_z = fs.skin - depth;
  double sum = 0.0;
  int n = 0;
  const double t_end = press_s + len / speed;
  for (double t = 0.0; t <= t_end + 1e-12; t += period) {
    const double u = std::min(1.0, t / press_s);
    const double x = x0 + std::max(0.0, t - press_s) * speed;
    const double z = fs.skin + 1.0 + u * (pad_z - fs.skin - 1.0);
    tick(m, st, Pose{{x, fs.mid_y, z - kFingerPadZ}, Quat{}});
    friction_bound(st, bound);
    if (x > x0 + 0.5 * len) {
      sum += -st.f_device.x;
      ++n;
    }
  }
  return n ? sum / n : std::nan("");
}

// Decay (%) of the lateral holding force over a 5 s jittered hold, shifted by half the breakaway
// distance at `depth`; the breakaway distance (mm) into *shift.
double creep_decay(const Model& m, const FlatScene& fs, double depth, double& shift, Bound& bound,
                   double& f_start, double& f_end) {
  const ForceParams& p = m.params();
  const double breakaway = p.model == ModelKind::Palp
                               ? p.mu * saturated_surface_force(depth, p.skin_fmax) / p.k
                               : p.c * surface_force(depth);
  shift = 0.5 * breakaway;
  State st = make_state(m);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> jit(-0.05, 0.05);
  const double x0 = 60.0, pad_z = fs.skin - depth;
  constexpr int kPress = 500, kShift = 200, kHold = 5000, kWin = 500;
  double s0 = 0.0, s1 = 0.0;
  for (int t = 0; t < kPress + kShift + kHold; ++t) {
    Vec3d pad{x0, fs.mid_y, pad_z};
    if (t < kPress) pad.z = fs.skin + 1.0 + (pad_z - fs.skin - 1.0) * t / kPress;
    if (t >= kPress) pad.x += shift * std::min(1.0, static_cast<double>(t - kPress) / kShift);
    const int h = t - kPress - kShift;
    if (h >= 0) {
      pad.x += jit(rng);
      pad.y += jit(rng);
    }
    tick(m, st, Pose{{pad.x, pad.y, pad.z - kFingerPadZ}, Quat{}});
    friction_bound(st, bound);
    if (h >= 0 && h < kWin) s0 += -st.f_device.x;
    if (h >= kHold - kWin) s1 += -st.f_device.x;
  }
  f_start = s0 / kWin;
  f_end = s1 / kWin;
  return 100.0 * (f_start - f_end) / f_start;
}

void friction(const Flags& flags, Csv& csv, Csv& creep_csv) {
  const FlatScene fs = flat_scene();
  for (const Variant& v : fs.vars) {
    ForceParams prm = model_params(v.model, ToolKind::Finger);
    prm.bone_enabled = false;
    const Model m(v.fields, parse_tool("finger:1"), prm);
    const char* name = to_string(v.model);
    Bound bound;
    // Speed.
    std::printf("friction %-5s 4 mm, 1 kHz, against speed:", name);
    double ref = 0.0;
    for (double speed : {100.0, 200.0, 400.0, 800.0}) {
      const double f = slide_friction(m, fs, 4.0, speed, 1000.0, bound);
      if (speed == 100.0) ref = f;
      csv.row({std::string(name), "speed", 4.0, speed, 1000.0, f, 100.0 * (f / ref - 1.0)});
      std::printf("  %g mm/s %.4f N (%+.1f %%)", speed, f, 100.0 * (f / ref - 1.0));
    }
    std::printf("\n");
    // Rate.
    for (double speed : {200.0, 800.0}) {
      std::printf("friction %-5s 4 mm, %g mm/s, against rate:", name, speed);
      const double f10 = slide_friction(m, fs, 4.0, speed, 10000.0, bound);
      for (double rate : {1000.0, 2000.0, 4000.0, 10000.0}) {
        const double f = rate == 10000.0 ? f10 : slide_friction(m, fs, 4.0, speed, rate, bound);
        csv.row({std::string(name), "rate", 4.0, speed, rate, f, 100.0 * (f / f10 - 1.0)});
        std::printf("  %g kHz %.4f N (%+.1f %%)", rate / 1000.0, f, 100.0 * (f / f10 - 1.0));
      }
      std::printf("\n");
    }
    // Creep.
    std::printf("creep    %-5s hold 5 s, +-0.05 mm jitter, decay of the holding force:", name);
    const std::vector<double> depths =
        flags.quick ? std::vector<double>{1, 3, 8} : std::vector<double>{1, 2, 3, 4, 5, 6, 7, 8};
    for (double d : depths) {
      double shift = 0.0, f0 = 0.0, f1 = 0.0;
      const double decay = creep_decay(m, fs, d, shift, bound, f0, f1);
      creep_csv.row({std::string(name), d, shift, f0, f1, decay});
      std::printf("  %g mm %.1f %%", d, decay);
    }
    std::printf("\n");
    std::printf(
        "bound    %-5s over every tick above: largest |f_friction| / f_n %.4f (mu %.2f), "
        "%ld point-ticks with friction and no pressing force\n",
        name, bound.mu_max, prm.mu, bound.no_press);
  }
}

// ---- 3. Skin smoothness on the real CT ---------------------------------------------------------

// D_surf at p sampled as sum_c w_c (D_c + g_c . (p - c) / 2) over the 8 nodes c around p, g_c the
// map's gradient at c by central differences: the mean of the trilinear sample and of the
// first-order Taylor expansions from the corners, whose quadratic errors are equal and opposite
// (a candidate for the tick, measured here only).
double gradient_corrected_surf(const FieldSampler& fields, const Grid& g, const Vec3d& p) {
  const auto at = [&](const Vec3d& x) { return fields.sample_surf(x).value; };
  const Vec3d ex{g.spacing[0], 0, 0}, ey{0, g.spacing[1], 0}, ez{0, 0, g.spacing[2]};
  double out = 0.0;
  for_each_node_around(g, p, [&](const Vec3d& node, double w) {
    const Vec3d grad{(at(node + ex) - at(node - ex)) / (2 * g.spacing[0]),
                     (at(node + ey) - at(node - ey)) / (2 * g.spacing[1]),
                     (at(node + ez) - at(node - ez)) / (2 * g.spacing[2])};
    out += w * (at(node) + 0.5 * dot(grad, p - node));
  });
  return out;
}

void smoothness(const std::string& ct_path, Csv& csv) {
  const std::vector<Variant> vars = variants_for(ct_path);
  Hu hu{read_ct(ct_path)};
  // The maps lie on the CT's grid or on its aligned refinement (prep/maps/map_refine.hpp).
  const Grid& map_grid = vars[0].fields->grid();
  if (refinement_between(hu.ct.grid, map_grid)[0] == 0) {
    std::printf("smooth: the CT was resampled by prep (grids differ): skipped\n");
    return;
  }
  for (const Variant& v : vars) {
    const Grid& g = v.fields->grid();
    std::printf("smooth: %s's maps on %lld x %lld x %lld nodes of %g mm\n", to_string(v.model),
                static_cast<long long>(g.dims[0]), static_cast<long long>(g.dims[1]),
                static_cast<long long>(g.dims[2]), g.spacing[0]);
  }
  RibsSpec spec;
  spec.azimuth_deg = 90.0;  // anterior
  spec.from = 0.30;
  spec.to = 0.60;
  const BodyAxis axis = ribs_body_axis(*vars[0].fields, spec);
  const Tool tool = parse_tool("finger:1");
  const double offset = pad_offset(tool);
  // PALP_SMOOTH_PATH: global (default), normal or exact; see the file's head.
  const char* path_env = std::getenv("PALP_SMOOTH_PATH");
  const std::string path_kind = path_env && *path_env ? path_env : "global";
  if (path_kind != "global" && path_kind != "normal" && path_kind != "exact")
    throw UsageError("PALP_SMOOTH_PATH: global, normal or exact, not " + path_kind);
  const char* pose_env = std::getenv("PALP_SMOOTH_POSE");
  const bool pose_from_ray = pose_env && std::string(pose_env) == "ray";
  const double rate = 1000.0, speed = 20.0;
  const double len = (spec.to - spec.from) * axis.extent;
  const int n = static_cast<int>(len / speed * rate);
  const int half = static_cast<int>(5.0 / speed * rate);  // 5 mm each side
  // The skin sheet around the path (20 mm beyond it on every side), for the global distance.
  const SkinSheet sheet(
      hu,
      [&](double a) {
        const double along = std::clamp(spec.from + a / axis.extent, 0.0, 1.0);
        return ribs_skin_frame(*vars[0].fields, axis, along).skin + 30.0 * axis.ray;
      },
      axis.ray, axis.superior, len, 20.0);
  std::printf("smooth: path %s, pad oriented by the %s\n", path_kind.c_str(),
              pose_from_ray ? "ray" : "HU normal at the skin point");
  for (double depth : {2.0, 4.0, 6.0}) {
    for (const Variant& v : vars) {
      ForceParams prm = model_params(v.model, tool.kind);
      prm.bone_enabled = false;
      const Model m(v.fields, tool, prm);
      State st = make_state(m);
      std::vector<double> f, map_depth, exact_depth, exact_nodes_depth,
          corrected_depth;    // map_depth: D_surf at the pad centre (nominal: depth)
      double skin_gap = 0.0;  // largest |D_surf| on the HU iso-surface: the maps' own error
      double pos_step = 0.0;  // the path's largest step between two ticks, mm
      double s_ray = depth;   // global: the pad's offset along -ray from the skin point
      Vec3d last{};
      // Every 50th tick (1 mm) of the first model's path: the depth by a brute-force sampling of
      // the iso-surface (0.1 mm lines in a cube of half-side depth + 1 mm), independent of the
      // descents, and the global distance's difference from it.
      std::vector<double> brute;
      double diff_lo = 0.0, diff_hi = 0.0;
      Trajectory path;  // the poses ticked, for PALP_SMOOTH_TRAJ_DIR
      for (int t = 0; t <= n; ++t) {
        const double along = spec.from + (spec.to - spec.from) * t / n;
        // Start 15 mm outside the map's skin point on the ray, come in to the HU iso-surface.
        const SkinFrame frame = ribs_skin_frame(*v.fields, axis, along);
        const Vec3d skin = hu.skin(frame.skin + 15.0 * axis.ray, axis.ray);
        skin_gap = std::max(skin_gap, std::fabs(v.fields->sample_surf(skin).value));
        const Vec3d nrm = pose_from_ray ? axis.ray : hu.normal(skin);
        const Quat q = surface_orientation(nrm, axis.superior);
        Vec3d pad = skin - depth * nrm;
        if (path_kind == "exact") {
          // Moved along the normal onto the exact depth of prep's descent from the skin point,
          // whose closest point can switch between two sheets: a step of the path itself.
          for (int it = 0; it < 3; ++it) pad = pad - (depth - hu.distance(pad, skin)) * nrm;
        } else if (path_kind == "global") {
          // The root of global distance - depth along the ray (a fixed direction, so the path is
          // as continuous as the distance), by secant steps from the last tick's offset.
          const auto g = [&](double s) { return sheet.global(skin - s * axis.ray) - depth; };
          double s0 = s_ray, g0 = g(s0), s1 = s0 - g0, g1 = g(s1);
          for (int it = 0; it < 30 && std::fabs(g1) > 1e-7 && g1 != g0; ++it) {
            const double s2 = s1 - g1 * (s1 - s0) / (g1 - g0);
            s0 = s1, g0 = g1, s1 = s2, g1 = g(s1);
          }
          s_ray = s1;
          pad = skin - s_ray * axis.ray;
        }
        if (t > 0) pos_step = std::max(pos_step, norm(pad - last));
        last = pad;
        const Pose pose = pad_pose(pad, nrm, q, offset);
        tick(m, st, pose);
        path.push_back({t / rate, pose});
        f.push_back(norm(st.f_device));
        map_depth.push_back(v.fields->sample_surf(pad).value);
        // The global distance from the pad centre to the trilinear HU's iso-surface, and the
        // trilinear interpolation of the global distances at the 8 grid nodes around it: what
        // the tick would read from a map exact at its nodes.
        exact_depth.push_back(sheet.global(pad));
        if (&v == &vars[0] && t % 50 == 0) {
          brute.push_back(sheet.brute_force(pad, depth + 1.0, 0.1));
          const double diff = exact_depth.back() - brute.back();
          diff_lo = std::min(diff_lo, diff), diff_hi = std::max(diff_hi, diff);
        }
        exact_nodes_depth.push_back(Hu::interpolated_node_distance(
            map_grid, pad, [&](const Vec3d& x) { return sheet.global_cached(x); }));
        corrected_depth.push_back(gradient_corrected_surf(*v.fields, map_grid, pad));
      }
      double sq = 0.0, step = 0.0, mean = 0.0, sq_depth = 0.0, sq_err = 0.0, sq_nodes = 0.0,
             sq_corrected = 0.0, sq_path = 0.0;
      int cnt = 0;
      for (int t = half; t + half < static_cast<int>(f.size()); ++t) {
        double avg = 0.0, avg_depth = 0.0, avg_path = 0.0;
        for (int j = t - half; j <= t + half; ++j)
          avg += f[j], avg_depth += map_depth[j], avg_path += exact_depth[j];
        avg /= 2 * half + 1;
        avg_depth /= 2 * half + 1;
        avg_path /= 2 * half + 1;
        sq_path += (exact_depth[t] - avg_path) * (exact_depth[t] - avg_path);
        sq += (f[t] - avg) * (f[t] - avg);
        sq_depth += (map_depth[t] - avg_depth) * (map_depth[t] - avg_depth);
        sq_err += (map_depth[t] - exact_depth[t]) * (map_depth[t] - exact_depth[t]);
        sq_nodes +=
            (exact_nodes_depth[t] - exact_depth[t]) * (exact_nodes_depth[t] - exact_depth[t]);
        sq_corrected +=
            (corrected_depth[t] - exact_depth[t]) * (corrected_depth[t] - exact_depth[t]);
        mean += f[t];
        ++cnt;
      }
      for (std::size_t t = 1; t < f.size(); ++t) step = std::max(step, std::fabs(f[t] - f[t - 1]));
      const double sd = std::sqrt(sq / cnt), sd_depth = std::sqrt(sq_depth / cnt);
      const double err = std::sqrt(sq_err / cnt), nodes_err = std::sqrt(sq_nodes / cnt);
      const double corrected_err = std::sqrt(sq_corrected / cnt);
      const double sd_path = std::sqrt(sq_path / cnt);
      if (!brute.empty()) {
        double sq_brute = 0.0;
        int nb = 0;
        for (int t = 5; t + 5 < static_cast<int>(brute.size()); ++t, ++nb) {
          double avg = 0.0;
          for (int j = t - 5; j <= t + 5; ++j) avg += brute[j];
          avg /= 11;
          sq_brute += (brute[t] - avg) * (brute[t] - avg);
        }
        std::printf(
            "smooth: %g mm path, its depth by brute force at %zu points: detrended std %.4f mm; "
            "the global distance minus it: %.4f to %.4f mm\n",
            depth, brute.size(), std::sqrt(sq_brute / nb), diff_lo, diff_hi);
      }
      if (const char* dir = std::getenv("PALP_SMOOTH_TRAJ_DIR"); dir && *dir && &v == &vars[0]) {
        char name[64];
        std::snprintf(name, sizeof name, "skin_path_%gmm.csv", depth);
        write_trajectory_csv((std::filesystem::path(dir) / name).string(), path);
      }
      csv.row({std::string(to_string(v.model)), depth, mean / cnt, sd, step, skin_gap, sd_depth,
               err, nodes_err, corrected_err, sd_path, pos_step});
      std::printf(
          "smooth %-5s finger:1 %g mm true depth, %.0f mm at 20 mm/s: mean %.3f N, detrended "
          "std %.3f N, largest tick step %.3f N (|D_surf| on the iso-surface up to %.2f mm; "
          "D_surf at the pad centre: detrended std %.3f mm, against the exact distance rms "
          "%.3f mm; exact nodes interpolated: rms %.3f mm; the map gradient-corrected: rms %.3f "
          "mm; the path's exact depth: detrended std %.4f mm, largest step %.4f mm)\n",
          to_string(v.model), depth, len, mean / cnt, sd, step, skin_gap, sd_depth, err, nodes_err,
          corrected_err, sd_path, pos_step);
    }
  }
}

// ---- 4. Contact-count independence on a curved surface -----------------------------------------

// A skin ball of radius 30 mm (exact signed distances at 0.5 mm, no bone); finger:1/7/19/37
// pressed along the radius to a pad depth of 2..8 mm (0.5 s at 1 kHz, held 0.1 s): the pressing
// force f_device . n against finger:1's.
void contact_count(Csv& csv) {
  const double h = 0.5, side = 80.0, radius = 30.0;
  const Vec3d c{40.0, 40.0, 40.0};
  Grid g;
  const auto n = static_cast<std::int64_t>(std::llround(side / h)) + 1;
  g.dims = {n, n, n};
  g.spacing = {h, h, h};
  DistanceMap surf(g, 0.0f, "ball");
  for (std::int64_t k = 0; k < n; ++k)
    for (std::int64_t j = 0; j < n; ++j)
      for (std::int64_t i = 0; i < n; ++i)
        surf.at(i, j, k) = static_cast<float>(
            radius - norm(Vec3d{static_cast<double>(i) * h, static_cast<double>(j) * h,
                                static_cast<double>(k) * h} -
                          c));
  const std::vector<Variant> vars = {
      {ModelKind::Paper, std::make_shared<const FieldSampler>(surf)},
      {ModelKind::Palp,
       std::make_shared<const FieldSampler>(
           surf, SamplerConfig{GradientScheme::PrecomputedField, Storage::Float32})}};
  SkinFrame frame;
  frame.normal = normalized(Vec3d{0.3, 0.4, 1.0});
  frame.skin = c + radius * frame.normal;
  frame.slide = normalized(cross(frame.normal, Vec3d{1, 0, 0}));
  for (const Variant& v : vars) {
    std::printf("contacts %-5s ball R 30 mm, pressing force against finger:1:", to_string(v.model));
    for (double d : {2.0, 4.0, 6.0, 8.0}) {
      double f1 = 0.0;
      std::printf("  %g mm", d);
      for (int pts : {1, 7, 19, 37}) {
        const Tool tool = parse_tool("finger:" + std::to_string(pts));
        const Model m(v.fields, tool, model_params(v.model, tool.kind));
        State st = make_state(m);
        const double f = press_force(m, st, frame, d, pad_offset(tool));
        if (pts == 1) f1 = f;
        csv.row({std::string(to_string(v.model)), d, static_cast<double>(pts), f,
                 100.0 * (f / f1 - 1.0)});
        if (pts != 1) std::printf(" %d:%+.1f%%", pts, 100.0 * (f / f1 - 1.0));
      }
    }
    std::printf("\n");
  }
}

}  // namespace
}  // namespace palp::study

int main(int argc, char** argv) {
  using namespace palp;
  using namespace palp::study;
  const Flags flags = parse_flags(argc, argv, "study_force_model [--out DIR] [--quick]");
  const double t0 = now_seconds();
  const char* env_ct = std::getenv("PALP_CT");
  const std::string ct = env_ct ? env_ct : "../shared/data/ct_abdomen_3mm.nii.gz";
  const bool have_ct = std::filesystem::exists(ct);
  if (!have_ct) std::printf("no CT at %s: its parts are skipped\n", ct.c_str());
  // PALP_STUDY_PARTS (e.g. "smooth" or "contrast,friction") runs only the parts named
  const char* env_parts = std::getenv("PALP_STUDY_PARTS");
  const auto want = [env_parts](const char* part) {
    return env_parts == nullptr || std::strstr(env_parts, part) != nullptr;
  };

  Csv c_csv(flags.out_dir + "/force_model_contrast.csv",
            {"scene", "tool", "model", "azimuth_deg", "depth_mm", "site", "pos_mm", "bone_below_mm",
             "force_N", "skin_only_N"});
  Csv r_csv(flags.out_dir + "/force_model_contrast_ratio.csv",
            {"scene", "tool", "model", "series", "depth_mm", "ratio_median", "ratio_min", "pairs"});
  const std::vector<double> depths =
      flags.quick ? std::vector<double>{2, 6, 12} : std::vector<double>{2, 4, 6, 8, 10, 12};
  std::vector<RibsSpec> torso_paths;
  for (double az : {0.0, 15.0, 30.0, 45.0}) {
    torso_paths.emplace_back();
    torso_paths.back().azimuth_deg = az;
  }
  Csv b_csv(flags.out_dir + "/force_model_bone_cost.csv",
            {"scene", "tool", "series", "bone_reach_mm", "depth_mm", "crest_bone_median_N",
             "crests", "far_bone_median_N", "far_bone_max_N", "far_sites"});
  if (want("contrast"))
    contrast("torso", "phantom:torso", torso_paths, depths, c_csv, r_csv, b_csv);
  if (have_ct && want("contrast")) {
    std::vector<RibsSpec> ct_paths;
    for (double az = -50.0; az <= 20.0; az += 10.0) {
      ct_paths.emplace_back();
      ct_paths.back().from = 0.55;
      ct_paths.back().to = 0.99;
      ct_paths.back().azimuth_deg = az;
    }
    contrast("ct", ct, ct_paths, depths, c_csv, r_csv, b_csv);
  }
  std::printf("contrast: %.1f s\n", now_seconds() - t0);

  Csv f_csv(flags.out_dir + "/force_model_friction.csv",
            {"model", "sweep", "depth_mm", "speed_mm_s", "rate_hz", "friction_N", "change_pct"});
  Csv k_csv(flags.out_dir + "/force_model_creep.csv",
            {"model", "depth_mm", "shift_mm", "f_start_N", "f_end_N", "decay_pct"});
  if (want("friction")) friction(flags, f_csv, k_csv);
  std::printf("friction: %.1f s\n", now_seconds() - t0);

  Csv n_csv(flags.out_dir + "/force_model_contacts.csv",
            {"model", "depth_mm", "points", "force_N", "vs_finger1_pct"});
  if (want("contacts")) contact_count(n_csv);

  Csv s_csv(flags.out_dir + "/force_model_smooth.csv",
            {"model", "depth_mm", "mean_N", "detrended_std_N", "max_step_N", "map_skin_error_mm",
             "map_depth_std_mm", "map_vs_exact_rms_mm", "exact_nodes_interp_rms_mm",
             "gradient_corrected_vs_exact_rms_mm", "path_depth_std_mm", "path_max_step_mm"});
  if (have_ct && want("smooth")) smoothness(ct, s_csv);
  std::printf("force_model: %.1f s\n", now_seconds() - t0);
  return 0;
}
