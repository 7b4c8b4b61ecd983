// study_structures: the structure layers felt on a scene (docs/force_model.md "Structures as
// layers", "Measured"). Deterministic and kinematic (no timing); the ticks are the ones `palp
// run` makes (the same Model, tick and trajectory generator), and the press it charts is also
// written as a trajectory so `palp run` can replay it (tests/bench/structures_chart.sh does).
//
//   pulse  the most superficial artery of the scene's d_artery (the centre-line voxel with the
//          least tissue above it): the skin point above it, its normal and the vessel's axis;
//          press_hold there at three preloads (the depth whose pressing force, pulse off, is 2,
//          3.5, 5 N) and three lateral offsets across the vessel (0, 8, 16 mm), 3 s at 1 kHz and
//          72 bpm; the pressing force against time, and per case the pulse's amplitude (max - min
//          of the pressing force over the last two beats) against the human range 0.02-0.5 N.
//          Then the press that occludes it (the force where the amplitude falls under 0.01 N).
//   liver  a slide across the organ layer's inferior edge at a fixed depth, with and without the
//          layer: the pressing force against position.
//
// usage: study_structures [--scene SCENE] [--tool TOOL] [--out DIR] [--cache-dir DIR]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "model/force_model.hpp"
#include "scene/scene.hpp"
#include "scene/trajectory.hpp"
#include "scene/trajectory_gen.hpp"

namespace palp {
namespace {

struct Site {
  Vec3d centre{}, skin{}, normal{}, axis{}, across{};
  double tissue_mm = 0.0;  // skin to the vessel's wall along the normal
};

Vec3d unit(Vec3d v) {
  const double n = norm(v);
  return n > 0.0 ? v * (1.0 / n) : v;
}

Vec3d node(const Grid& g, std::int64_t i, std::int64_t j, std::int64_t k) {
  return {i * g.spacing[0], j * g.spacing[1], k * g.spacing[2]};
}

// The artery's centre-line voxel with the least tissue above it (D_surf - D_artery least among
// voxels at least 2.5 mm inside a lumen), the skin point above it and the vessel's axis (the
// principal direction of the lumen's voxels within 12 mm).
Site find_site(const DistanceMap& artery, const FieldSampler& fields) {
  const Grid& g = artery.grid;
  struct Voxel {
    Vec3d p;
    double tissue;
  };
  std::vector<Voxel> line;  // voxels at least 2.5 mm inside a lumen, with the tissue above them
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const double d = artery.at(i, j, k);
        if (d < 2.5) continue;
        const FieldSample s = fields.sample_surf(node(g, i, j, k));
        if (s.inside) line.push_back({node(g, i, j, k), s.value - d});
      }
  if (line.empty()) throw InputError("the scene's artery has no lumen 5 mm across");
  double least = 1e300;
  for (const Voxel& v : line) least = std::min(least, v.tissue);
  // The most superficial run (within 1 mm of the least tissue), and its middle along k: away from
  // where a deeper branch joins it.
  std::vector<Voxel> run;
  for (const Voxel& v : line)
    if (v.tissue <= least + 1.0) run.push_back(v);
  std::sort(run.begin(), run.end(), [](const Voxel& a, const Voxel& b) { return a.p.z < b.p.z; });
  Site site;
  site.centre = run[run.size() / 2].p;
  const double best = run[run.size() / 2].tissue;
  const FieldSample s = fields.sample_surf(site.centre);
  site.normal = unit(s.grad * -1.0);
  site.skin = site.centre + s.value * site.normal;
  site.tissue_mm = best;
  // The axis: power iteration on the covariance of the lumen's voxels near the centre.
  double c[3][3] = {};
  const double r = 8.0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const Vec3d q = node(g, i, j, k) - site.centre;
        if (artery.at(i, j, k) <= 0.0f || norm(q) > r) continue;
        const double v[3] = {q.x, q.y, q.z};
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) c[a][b] += v[a] * v[b];
      }
  Vec3d axis{0.3, 0.5, 0.8};
  for (int it = 0; it < 100; ++it)
    axis = unit({c[0][0] * axis.x + c[0][1] * axis.y + c[0][2] * axis.z,
                 c[1][0] * axis.x + c[1][1] * axis.y + c[1][2] * axis.z,
                 c[2][0] * axis.x + c[2][1] * axis.y + c[2][2] * axis.z});
  site.axis = axis;
  site.across = unit(cross(site.normal, axis));
  return site;
}

// The skin point `offset` mm across from the site's, and its normal.
SurfaceAnchor anchor_at(const FieldSampler& fields, const Site& site, double offset) {
  Vec3d p = site.skin + offset * site.across;
  for (int it = 0; it < 4; ++it) {  // onto the skin along its normal
    const FieldSample s = fields.sample_surf(p);
    p += s.value * unit(s.grad * -1.0);
  }
  SurfaceAnchor a;
  a.point = p;
  a.normal = unit(fields.sample_surf(p).grad * -1.0);
  a.slide = unit(site.axis - dot(site.axis, a.normal) * a.normal);
  return a;
}

// The pressing force at rest at depth `depth` (pulse off: the wave stands at 0).
double pressing_force(const Model& model, const SurfaceAnchor& a, double depth) {
  State st = make_state(model);
  st.pulse_bpm = 0.0;
  const Pose pose = pad_pose(a.point - depth * a.normal, a.normal,
                             surface_orientation(a.normal, a.slide), pad_offset(model.tool()));
  tick(model, st, pose, 0.0);
  return dot(st.f_device, a.normal);
}

double depth_for(const Model& model, const SurfaceAnchor& a, double force) {
  double lo = 0.0, hi = 30.0;
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    (pressing_force(model, a, mid) < force ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// press_hold to `depth` (1 s press, 2.5 s hold), 1 kHz; the pressing force per row.
std::vector<double> press(const Model& model, const SurfaceAnchor& a, double depth,
                          Trajectory* rows = nullptr) {
  PressHoldSpec spec;
  spec.depth_mm = depth;
  spec.press_s = 1.0;
  spec.hold_s = 2.5;
  const Trajectory path = press_hold(a, pad_offset(model.tool()), spec);
  State st = make_state(model);
  std::vector<double> f;
  for (const TrajectorySample& row : path) {
    tick(model, st, row.pose, row.t);
    f.push_back(dot(st.f_device, a.normal));
  }
  if (rows) *rows = path;
  return f;
}

// max - min over the last two beats at 72 bpm (1 kHz rows).
double amplitude(const std::vector<double>& f) {
  const std::size_t window = 1667;
  const auto first = f.end() - static_cast<std::ptrdiff_t>(std::min(window, f.size()));
  return *std::max_element(first, f.end()) - *std::min_element(first, f.end());
}

// The organ's inferior edge under the skin: its lowest voxel (least k, the scene's inferior end
// on an LPS grid) within 40 mm of the skin; the skin point above it; a slide along +-k across it
// at 8 mm, with and without the organ's layer. -> organ_slide.csv (position, both forces).
void organ_edge(const Scene& scene, const Model& model, const Model& bare, const std::string& name,
                const std::string& out) {
  const DistanceMap organ = read_nifti_float(
      (std::filesystem::path(scene.prep_dir) / ("d_" + name + ".nii.gz")).string());
  const Grid& g = organ.grid;
  Vec3d edge{};
  bool found = false;
  for (std::int64_t k = 0; k < g.dims[2] && !found; ++k)
    for (std::int64_t j = 0; j < g.dims[1] && !found; ++j)
      for (std::int64_t i = 0; i < g.dims[0] && !found; ++i) {
        if (organ.at(i, j, k) <= 0.0f) continue;
        const FieldSample s = scene.fields->sample_surf(node(g, i, j, k));
        if (s.inside && s.value < 40.0) edge = node(g, i, j, k), found = true;
      }
  if (!found) {
    std::printf("%s: no part within 40 mm of the skin\n", name.c_str());
    return;
  }
  const FieldSample s = scene.fields->sample_surf(edge);
  SurfaceAnchor a;
  a.normal = unit(s.grad * -1.0);
  a.point = edge + s.value * a.normal;
  a.slide = unit(Vec3d{0, 0, 1} - a.normal.z * a.normal);
  SlideRampSpec spec;
  spec.duration_s = 6.0;
  spec.speed_mm_s = 10.0;  // 60 mm: 30 mm either side of the edge
  spec.depth_start_mm = spec.depth_end_mm = 8.0;
  const Trajectory path = slide_ramp(a, pad_offset(model.tool()), spec);
  State with = make_state(model), without = make_state(bare);
  std::FILE* csv = std::fopen((std::filesystem::path(out) / "organ_slide.csv").c_str(), "w");
  std::fprintf(csv, "along_mm,f_with_%s,f_without\n", name.c_str());
  double over = 0.0, past = 0.0;
  for (const TrajectorySample& row : path) {
    tick(model, with, row.pose, row.t);
    tick(bare, without, row.pose, row.t);
    const double along = dot(row.pose.position - a.point, a.slide);
    const double fw = dot(with.f_device, a.normal), fo = dot(without.f_device, a.normal);
    std::fprintf(csv, "%.2f,%.4f,%.4f\n", along, fw, fo);
    if (std::fabs(along - 15.0) < 0.05) over = fw - fo;
    if (std::fabs(along + 15.0) < 0.05) past = fw - fo;
  }
  std::fclose(csv);
  std::printf(
      "%s edge at (%.1f, %.1f, %.1f) mm, %.1f mm under the skin; sliding across it at 8 mm: "
      "the layer adds %.3f N 15 mm above the edge and %.3f N 15 mm below\n",
      name.c_str(), edge.x, edge.y, edge.z, s.value, over, past);
}

int run(int argc, char** argv) {
  std::string scene_name = "phantom:torso,structures", tool_name = "finger:1";
  std::string out = "build/studies/structures";
  SceneOptions options;
  options.sampler = {GradientScheme::PrecomputedField, Storage::Interleaved};
  options.map_spacing_mm = kPalpMapSpacingMm;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i], value = argv[i + 1];
    if (key == "--scene")
      scene_name = value;
    else if (key == "--tool")
      tool_name = value;
    else if (key == "--out")
      out = value;
    else if (key == "--cache-dir")
      options.cache_dir = value;
    else
      throw UsageError("study_structures: unknown option " + key);
  }
  std::filesystem::create_directories(out);
  const Scene scene = load_scene(scene_name, options);
  const Tool tool = parse_tool(tool_name);
  const ForceParams params = palp_params(tool.kind);
  const Model model(scene.fields, tool, params, scene.layers);
  const Model bare(scene.fields, tool, params);
  const std::filesystem::path dir(scene.prep_dir);
  // The artery layer's map: d_artery, or the arterial phase's d_vessel (scene.hpp).
  std::string artery_file;
  for (std::size_t i = 0; i < scene.layers->size(); ++i)
    if (scene.layers->kind(i) == LayerKind::Artery)
      artery_file = scene.layer_sources[i].substr(0, scene.layer_sources[i].find(' '));
  if (artery_file.empty()) throw InputError(scene_name + ": no artery layer in " + scene.prep_dir);
  std::printf("artery: %s\n", artery_file.c_str());
  const Site site = find_site(read_nifti_float((dir / artery_file).string()), *scene.fields);
  std::printf(
      "site: skin (%.1f, %.1f, %.1f) mm, normal (%.2f, %.2f, %.2f), vessel axis (%.2f, "
      "%.2f, %.2f), %.1f mm of tissue above the lumen\n",
      site.skin.x, site.skin.y, site.skin.z, site.normal.x, site.normal.y, site.normal.z,
      site.axis.x, site.axis.y, site.axis.z, site.tissue_mm);

  const double preloads[] = {2.0, 3.5, 5.0}, offsets[] = {0.0, 8.0, 16.0};
  std::vector<std::vector<double>> series;
  std::vector<std::string> names;
  std::FILE* table = std::fopen((std::filesystem::path(out) / "pulse_table.csv").c_str(), "w");
  std::fprintf(table, "preload_N,offset_mm,depth_mm,amplitude_N,in_range\n");
  std::printf(
      "| preload | offset | press depth | amplitude | in 0.02-0.5 N |\n|---|---|---|---|---|\n");
  for (double offset : offsets) {
    const SurfaceAnchor a = anchor_at(*scene.fields, site, offset);
    for (double preload : preloads) {
      const double depth = depth_for(bare, a, preload);
      Trajectory rows;
      series.push_back(press(model, a, depth, &rows));
      if (offset == 0.0 && preload == 3.5)
        write_trajectory_csv((std::filesystem::path(out) / "press_3.5N.csv").string(), rows);
      const double amp = amplitude(series.back());
      const bool in = amp >= 0.02 && amp <= 0.5;
      names.push_back("f_" + std::to_string(static_cast<int>(preload * 10)) + "dN_" +
                      std::to_string(static_cast<int>(offset)) + "mm");
      std::fprintf(table, "%g,%g,%.3f,%.4f,%d\n", preload, offset, depth, amp, in ? 1 : 0);
      std::printf("| %.1f N | %.0f mm | %.2f mm | %.3f N | %s |\n", preload, offset, depth, amp,
                  in ? "yes" : "no");
    }
  }
  std::fclose(table);
  // The occluding press at the site: the least preload (0.5 N steps) whose amplitude < 0.01 N.
  const SurfaceAnchor above = anchor_at(*scene.fields, site, 0.0);
  for (double preload = 5.5; preload <= 20.0; preload += 0.5) {
    if (amplitude(press(model, above, depth_for(bare, above, preload))) < 0.01) {
      std::printf("occluded from %.1f N of preload (amplitude under 0.01 N)\n", preload);
      break;
    }
  }
  std::FILE* csv = std::fopen((std::filesystem::path(out) / "pulse_force.csv").c_str(), "w");
  std::fprintf(csv, "t");
  for (const std::string& n : names) std::fprintf(csv, ",%s", n.c_str());
  std::fprintf(csv, "\n");
  for (std::size_t r = 0; r < series[0].size(); ++r) {
    std::fprintf(csv, "%.3f", 1e-3 * static_cast<double>(r));
    for (const auto& s : series) std::fprintf(csv, ",%.5f", r < s.size() ? s[r] : 0.0);
    std::fprintf(csv, "\n");
  }
  std::fclose(csv);
  for (std::size_t i = 0; i < scene.layers->size(); ++i)
    if (scene.layers->kind(i) == LayerKind::Organ)
      organ_edge(scene, model, bare, scene.layers->name(i), out);
  return 0;
}

}  // namespace
}  // namespace palp

int main(int argc, char** argv) {
  try {
    return palp::run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "study_structures: %s\n", e.what());
    return 1;
  }
}
