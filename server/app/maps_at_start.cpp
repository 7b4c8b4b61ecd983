// palpd's maps cut to its device's reach: see maps_at_start.hpp.
#include "app/maps_at_start.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "base/errors.hpp"
#include "devices/device.hpp"

namespace palp::app {
namespace {

Box grow(const Box& b, double by) {
  return {b.lo - Vec3d{by, by, by}, b.hi + Vec3d{by, by, by}};
}

double mib(std::size_t bytes) {
  return static_cast<double>(bytes) / 1048576.0;
}

}  // namespace

Box placed_reach(const Registration& r, const Vec3d& half) {
  Box b{{1e300, 1e300, 1e300}, {-1e300, -1e300, -1e300}};
  for (int c = 0; c < 8; ++c) {
    const Vec3d corner{c & 1 ? half.x : -half.x, c & 2 ? half.y : -half.y,
                       c & 4 ? half.z : -half.z};
    const Vec3d p = point_to_scene(r, corner);
    b.lo = {std::min(b.lo.x, p.x), std::min(b.lo.y, p.y), std::min(b.lo.z, p.z)};
    b.hi = {std::max(b.hi.x, p.x), std::max(b.hi.y, p.y), std::max(b.hi.z, p.z)};
  }
  return b;
}

Box path_reach(const Trajectory& path) {
  if (path.empty()) throw InputError("map window: an empty path reaches nothing");
  Box b{path.front().pose.position, path.front().pose.position};
  for (const TrajectorySample& row : path) {
    const Vec3d& p = row.pose.position;
    b.lo = {std::min(b.lo.x, p.x), std::min(b.lo.y, p.y), std::min(b.lo.z, p.z)};
    b.hi = {std::max(b.hi.x, p.x), std::max(b.hi.y, p.y), std::max(b.hi.z, p.z)};
  }
  return b;
}

double tool_reach(const Tool& tool) {
  double reach = 0.0;
  for (const Vec3d& p : tool.points) reach = std::max(reach, norm(p));
  return reach;
}

std::size_t haptic_map_bytes(const FieldSampler& f) {
  return f.grid().voxel_count() * (f.bytes_per_voxel() + (f.has_bone_beneath() ? 4 : 0));
}

MapsAtStart maps_at_start(const cli::Args& args, const rt::Device& device, Scene& scene,
                          const std::optional<net::SceneDescription::Placement>& placement,
                          const Tool& tool, bool quiet) {
  MapsAtStart out;
  out.haptic = scene.fields;
  const std::string mode = args.get("map-window").value_or("auto");
  double margin = kDefaultReCentreMarginMm;
  if (mode != "auto" && mode != "off") {
    char* end = nullptr;
    margin = std::strtod(mode.c_str(), &end);
    if (mode.empty() || *end != '\0' || !(margin >= 0.0 && margin <= 1000.0))
      throw UsageError("--map-window needs auto, off or a margin in mm (0..1000), got '" + mode +
                       "'");
  }
  if (mode == "off") return out;
  std::optional<Trajectory> path;  // a scripted device's (sim), asked for with MM only
  if (!placement && mode != "auto") path = device.scripted_path(*scene.fields, tool);
  Box reach;
  if (placement) {
    reach = placed_reach(placement->registration, placement->workspace_half_mm);
  } else if (path) {
    reach = path_reach(*path);
  } else {
    if (mode != "auto" && !quiet)
      std::fprintf(stderr,
                   "palpd: note: --map-window: the %s device's reach is not known: whole maps\n",
                   std::string(device.kind()).c_str());
    return out;
  }
  const Box box = grow(reach, margin + tool_reach(tool));
  out.window = window_for_box(scene.fields->grid(), box.lo, box.hi);
  // the maps as the scene's sampler has them (refined in memory as at load)
  SceneMaps maps = read_scene_maps(scene);
  DistanceMap& surf = maps.surf;
  DistanceMap& bone = maps.bone;
  out.haptic = window_sampler(surf, bone, *scene.fields, out.window, scene.fields->config());
  // (after it: the whole maps' bone-beneath map is traced by now, as the window's)
  const std::size_t whole_bytes = haptic_map_bytes(*scene.fields);
  // The window's sampler is complete (bone-beneath included) before the whole one goes.
  out.haptic->prepare_bone_beneath();
  out.windowed = true;
  // The render volume samples values only: the whole maps without gradient fields or
  // bone-beneath map (the same trilinear values as any scheme's, float32).
  scene.fields.reset();
  scene.fields = std::make_shared<const FieldSampler>(
      std::move(surf), std::move(bone),
      SamplerConfig{GradientScheme::AnalyticTrilinear, Storage::Float32});
  // Where the home may go with the workspace still inside the window (placed devices).
  if (placement) {
    const Vec3d home = placement->registration.home;
    out.home_room = grow(Box{home, home}, margin);
    out.placed = true;
  }
  char note[256];
  std::snprintf(note, sizeof note,
                "maps cut to the device's reach + %g mm: window %lldx%lldx%lld voxels, %.1f MiB "
                "(whole maps %.1f MiB, %.1fx less)",
                margin, static_cast<long long>(out.window.dims[0]),
                static_cast<long long>(out.window.dims[1]),
                static_cast<long long>(out.window.dims[2]), mib(haptic_map_bytes(*out.haptic)),
                mib(whole_bytes),
                static_cast<double>(whole_bytes) /
                    static_cast<double>(std::max<std::size_t>(haptic_map_bytes(*out.haptic), 1)));
  out.note = note;
  if (!quiet) std::fprintf(stderr, "palpd: %s\n", out.note.c_str());
  return out;
}

void warn_if_home_left_window(MapsAtStart& maps, const Vec3d& home) {
  if (!maps.windowed || !maps.placed || maps.warned) return;
  const Box& r = maps.home_room;
  if (home.x >= r.lo.x && home.x <= r.hi.x && home.y >= r.lo.y && home.y <= r.hi.y &&
      home.z >= r.lo.z && home.z <= r.hi.z)
    return;
  maps.warned = true;
  std::fprintf(stderr,
               "palpd: warning: the device was re-centred beyond the maps' window (--map-window "
               "margin): where it reaches past the window it feels nothing, as outside the body; "
               "restart palpd there, or give a larger --map-window\n");
}

}  // namespace palp::app
