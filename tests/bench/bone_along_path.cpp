// bone_along_path — where the bone lies under a tool moving along a trajectory (for the paper's
// Fig. 5a: are the force peaks over ribs?). Uses the scene's own bone distance map D_bone.
//
//   bone_along_path --scene SCENE --tool TOOL --trajectory FILE --out FILE.csv
//                   [--ray MM] [--cache-dir DIR]
//
// For every trajectory row, with n = the tool's +z (the outward skin normal for palp's
// generated paths) and the pad centre c = the centroid of the tool's contact points:
//   pad_depth_mm    D_surf(c): how deep the pad centre sits below the skin
//   bone_dist_mm    -D_bone(c): distance from the pad centre to the nearest bone (<= 0 inside)
//   bone_below_mm   distance along -n from c to the first point with D_bone >= 0 (bone), within
//                   --ray mm (default 30); empty when no bone is hit
//   bone_cover      fraction of the contact points whose own ray along -n hits bone within --ray
//   bone_dist_min_mm  the smallest -D_bone over the contact points
// It measures; it is not a test.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <limits>
#include <string>
#include <string_view>

#include "base/errors.hpp"
#include "base/vec.hpp"
#include "bench_main.hpp"
#include "model/field_sampler.hpp"
#include "model/tool.hpp"
#include "scene/scene.hpp"
#include "scene/trajectory.hpp"

namespace {

using namespace palp;

constexpr const char* kUsage =
    "usage: bone_along_path --scene SCENE --tool TOOL --trajectory FILE --out FILE.csv\n"
    "                       [--ray MM] [--cache-dir DIR]\n";

// Distance along `dir` from `from` to the first sample inside bone (D_bone >= 0), stepping
// `step` mm up to `length` mm; NaN when none.
double ray_to_bone(const FieldSampler& fields, const Vec3d& from, const Vec3d& dir, double length,
                   double step) {
  for (double s = 0.0; s <= length; s += step) {
    const FieldSample b = fields.sample_bone(from + dir * s);
    if (b.inside && b.value >= 0.0) return s;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

int run(int argc, char** argv) {
  std::string scene_name, tool_name, trajectory, out, cache_dir;
  double ray = 30.0;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError(std::string(a) + " needs a value");
      return argv[++i];
    };
    if (a == "--scene") {
      scene_name = value();
    } else if (a == "--tool") {
      tool_name = value();
    } else if (a == "--trajectory") {
      trajectory = value();
    } else if (a == "--out") {
      out = value();
    } else if (a == "--cache-dir") {
      cache_dir = value();
    } else if (a == "--ray") {
      const std::string v = value();
      char* end = nullptr;
      ray = std::strtod(v.c_str(), &end);
      if (v.empty() || *end != '\0' || !(ray > 0.0 && ray < 1000.0))
        throw UsageError("--ray needs a length in mm (0 to 1000)");
    } else if (a == "-h" || a == "--help") {
      std::fputs(kUsage, stdout);
      return 0;
    } else {
      throw UsageError("unknown argument '" + std::string(a) + "'");
    }
  }
  if (scene_name.empty() || tool_name.empty() || trajectory.empty() || out.empty())
    throw UsageError("--scene, --tool, --trajectory and --out are required");

  SceneOptions options;
  options.cache_dir = cache_dir;
  const Scene scene = load_scene(scene_name, options);
  const FieldSampler& fields = *scene.fields;
  if (!fields.has_bone()) throw InputError(scene_name + ": the scene has no bone map");
  const Tool tool = parse_tool(tool_name);
  Vec3d centroid{};
  for (const Vec3d& q : tool.points) centroid += q;
  centroid *= 1.0 / static_cast<double>(tool.points.size());
  const Trajectory path = read_trajectory_csv(trajectory);
  const double step = 0.25 * fields.grid().min_spacing();

  std::FILE* f = std::fopen(out.c_str(), "w");
  if (!f) throw InputError("cannot write " + out);
  std::fprintf(f, "t,pad_depth_mm,bone_dist_mm,bone_below_mm,bone_cover,bone_dist_min_mm\n");
  std::size_t over = 0;
  for (const TrajectorySample& row : path) {
    const Vec3d n = rotate(row.pose.orientation, Vec3d{0.0, 0.0, 1.0});
    const Vec3d c = row.pose.position + rotate(row.pose.orientation, centroid);
    const double depth = fields.sample_surf(c).value;
    const double dist = -fields.sample_bone(c).value;
    const double below = ray_to_bone(fields, c, -n, ray, step);
    int hits = 0;
    double dist_min = std::numeric_limits<double>::infinity();
    for (const Vec3d& q : tool.points) {
      const Vec3d x = row.pose.position + rotate(row.pose.orientation, q);
      dist_min = std::min(dist_min, -fields.sample_bone(x).value);
      hits += std::isfinite(ray_to_bone(fields, x, -n, ray, step)) ? 1 : 0;
    }
    const double cover = static_cast<double>(hits) / static_cast<double>(tool.points.size());
    over += std::isfinite(below) ? 1 : 0;
    std::fprintf(f, "%.6g,%.6g,%.6g,", row.t, depth, dist);
    if (std::isfinite(below)) std::fprintf(f, "%.6g", below);
    std::fprintf(f, ",%.6g,%.6g\n", cover, dist_min);
  }
  if (std::fclose(f) != 0) throw InputError("cannot write " + out);
  std::printf("wrote %s: %zu rows, bone within %.0f mm below the pad centre on %zu\n", out.c_str(),
              path.size(), ray, over);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return palp::bench::bench_main("bone_along_path", kUsage, run, argc, argv);
}
