// palp bench --scene SCENE --tool TOOL --ticks N: times the force model's tick in-process.
//   poses (a trajectory, or a generated path over the skin, back and forth) -> warm-up ticks
//   -> timed ticks (steady_clock around each) -> percentiles -> human lines, then one JSON line
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "base/errors.hpp"
#include "cli/commands.hpp"
#include "cli_common/cli.hpp"
#include "cli_common/config_file.hpp"
#include "cli_common/model_setup.hpp"
#include "model/force_model.hpp"
#include "model/map_window.hpp"
#include "scene/trajectory.hpp"
#include "scene/trajectory_gen.hpp"

namespace palp::cli {
namespace {

using Clock = std::chrono::steady_clock;

constexpr const char* kBenchUsage =
    R"(usage: palp bench --scene SCENE --tool TOOL --ticks N [options]
       palp bench --config FILE [--ticks N] [options]

Times the force model's tick in-process: after a warm-up, each tick is timed with steady_clock
(the clock's own cost, printed, is included). The poses come from --trajectory, or by default
from the `palp traj ribs` path over the scene's skin (the flat slide-speed path where the scene
has no body axis), run back and forth so every contact is real. Prints human-readable lines,
then, last on stdout, one JSON line: tick_ns_p50, tick_ns_p90, tick_ns_p99, tick_ns_p999,
tick_ns_max, tick_ns_mean, contacts (tool points), in_contact_mean, and the setup.
Options:
)";

constexpr const char* kBenchOptions =
    R"(  --tool TOOL             finger:N (N = 1, 7, 19, 37), twofinger:N or probe:NXxNY (required)
  --ticks N               timed ticks (default 100000)
  --warmup N              untimed ticks first (default 2000)
  --trajectory FILE       poses to tick through (default: the generated path)
  --param NAME=VALUE      force parameter override, repeatable (as in palp run)
  --window-mm M           keep only the maps' window the path can reach: the box of its device
                          positions widened by the tool's reach and M mm (docs/tuning.md); the
                          JSON's maps_mib is then the window's, whole_maps_mib the scene's
  --ticks-csv FILE        also write every timed tick as CSV (tick, pose, ns, status,
                          in_contact; status as in force_model.hpp): where the tail comes from
                          (tests/bench/tick_tail.py reads it)
  --config FILE           TOML with scene, tool, model, scheme, storage, param (e.g. what
                          palp tune --out writes): bench that configuration; the command line
                          wins
  -q, --quiet             print only the JSON line
  -h, --help              show this help
)";

// The maps a model on `fields` holds (values, gradient fields, palp's bone-beneath map), MiB.
double maps_mib(const FieldSampler& fields, const ForceParams& params) {
  const bool beneath =
      params.model == ModelKind::Palp && params.bone_along_normal && fields.has_bone();
  return static_cast<double>(fields.grid().voxel_count() *
                             (fields.bytes_per_voxel() + (beneath ? 4 : 0))) /
         1048576.0;
}

std::size_t parse_count(const Args& args, const std::string& key, double fallback) {
  const double n = args.number(key, fallback);
  if (!(n >= 0.0 && n <= 1e9 && n == std::floor(n)))
    throw UsageError("--" + key + " needs a whole number from 0 to 1e9");
  return static_cast<std::size_t>(n);
}

// The default poses: the ribs path, or the slide-speed path on a flat anchor.
Trajectory default_path(const FieldSampler& fields, double offset, std::string* name) {
  try {
    *name = "ribs";
    return ribs_slide(fields, offset, RibsSpec{});
  } catch (const InputError&) {
    *name = "slide-speed";
    return slide_speed(find_surface_anchor(fields, ApproachSide::Auto), offset, SlideSpeedSpec{});
  }
}

// Index into a path run back and forth: 0, 1, ..., n-1, n-2, ..., 1, 0, 1, ...
std::size_t ping_pong(std::size_t i, std::size_t n) {
  if (n < 2) return 0;
  const std::size_t period = 2 * (n - 1);
  const std::size_t r = i % period;
  return r < n ? r : period - r;
}

// Median cost of one pair of clock reads (ns).
double clock_pair_ns() {
  std::vector<std::int64_t> samples(1001);
  for (auto& s : samples) {
    const auto t0 = Clock::now();
    const auto t1 = Clock::now();
    s = std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - t0).count();
  }
  std::nth_element(samples.begin(), samples.begin() + 500, samples.end());
  return static_cast<double>(samples[500]);
}

struct Timings {
  std::vector<std::int64_t> ns;   // per timed tick
  std::vector<std::size_t> pose;  // its index in the path
  std::vector<std::uint32_t> status;
  std::vector<int> in_contact;
  double in_contact_sum = 0.0;
  std::size_t ticks_touching = 0;
};

Timings time_ticks(const Model& model, const Trajectory& path, std::size_t warmup,
                   std::size_t ticks) {
  State state = make_state(model);
  const std::size_t n = path.size();
  // the pulse's clock at 1 kHz (structure layers: the artery's term is computed every tick)
  for (std::size_t i = 0; i < warmup; ++i)
    tick(model, state, path[ping_pong(i, n)].pose, 1e-3 * static_cast<double>(i));
  Timings out;
  out.ns.resize(ticks);
  out.pose.resize(ticks);
  out.status.resize(ticks);
  out.in_contact.resize(ticks);
  for (std::size_t i = 0; i < ticks; ++i) {
    out.pose[i] = ping_pong(warmup + i, n);
    const Pose& pose = path[out.pose[i]].pose;
    const auto t0 = Clock::now();
    tick(model, state, pose, 1e-3 * static_cast<double>(warmup + i));
    const auto t1 = Clock::now();
    out.ns[i] = std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - t0).count();
    out.status[i] = state.status;
    out.in_contact[i] = state.n_contact;
    out.in_contact_sum += state.n_contact;
    out.ticks_touching += state.n_contact > 0;
  }
  return out;
}

void write_ticks_csv(const std::string& path, const Timings& t) {
  if (path.empty()) throw UsageError("--ticks-csv needs a file");
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) throw InputError("bench: cannot write " + path);
  std::fprintf(f, "tick,pose,ns,status,in_contact\n");
  for (std::size_t i = 0; i < t.ns.size(); ++i)
    std::fprintf(f, "%zu,%zu,%lld,%u,%d\n", i, t.pose[i], static_cast<long long>(t.ns[i]),
                 t.status[i], t.in_contact[i]);
  if (std::fclose(f) != 0) throw InputError("bench: cannot write " + path);
}

struct Summary {
  double p50 = 0, p90 = 0, p99 = 0, p999 = 0, max = 0, mean = 0;
};

// Nearest-rank percentiles of the sorted samples.
Summary summarize(std::vector<std::int64_t> ns) {
  Summary s;
  if (ns.empty()) return s;
  std::sort(ns.begin(), ns.end());
  auto rank = [&](double p) {
    const double r = std::ceil(p * static_cast<double>(ns.size()));
    const std::size_t i = static_cast<std::size_t>(std::max(r, 1.0)) - 1;
    return static_cast<double>(ns[std::min(i, ns.size() - 1)]);
  };
  s.p50 = rank(0.50);
  s.p90 = rank(0.90);
  s.p99 = rank(0.99);
  s.p999 = rank(0.999);
  s.max = static_cast<double>(ns.back());
  double sum = 0.0;
  for (std::int64_t v : ns) sum += static_cast<double>(v);
  s.mean = sum / static_cast<double>(ns.size());
  return s;
}

std::string json_string(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\u%04x", static_cast<unsigned>(c));
      out += escaped;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

// The maps' window a path can reach: the box of its device positions widened by the tool's
// reach and `margin_mm` (--window-mm), as a sampler over that window alone.
std::shared_ptr<const FieldSampler> window_around_path(const Scene& scene, const Tool& tool,
                                                       const Trajectory& path, double margin_mm) {
  double reach = 0.0;
  for (const Vec3d& p : tool.points) reach = std::max(reach, norm(p));
  Vec3d lo = path.front().pose.position, hi = lo;
  for (const TrajectorySample& row : path) {
    lo = {std::min(lo.x, row.pose.position.x), std::min(lo.y, row.pose.position.y),
          std::min(lo.z, row.pose.position.z)};
    hi = {std::max(hi.x, row.pose.position.x), std::max(hi.y, row.pose.position.y),
          std::max(hi.z, row.pose.position.z)};
  }
  const Vec3d widen{reach + margin_mm, reach + margin_mm, reach + margin_mm};
  const MapWindow window = window_for_box(scene.fields->grid(), lo - widen, hi + widen);
  const SceneMaps maps = read_scene_maps(scene);  // as the scene's sampler has them
  return window_sampler(maps.surf, maps.bone, *scene.fields, window, scene.fields->config());
}

// What one bench run measured and on what, for its two reports.
struct BenchResult {
  std::string scene, tool, path_name;
  const char* scheme = "";
  const char* storage = "";
  std::size_t poses = 0, ticks = 0, warmup = 0, points = 0;
  Summary tick;
  Summary bare;  // the same ticks without the structure layers (zeros without layers)
  std::size_t layers = 0;
  std::string first_layer;
  double in_contact_mean = 0, touching = 0, clock_ns = 0, model_mib = 0, whole_mib = 0;
  const FieldSampler* window = nullptr;  // the maps' window (--window-mm), or null: the scene's
};

// The human lines: setup, tick percentiles, contacts, the clock, the maps, the layers' cost.
void print_bench(const BenchResult& b) {
  const Summary& s = b.tick;
  std::printf(
      "bench %s on %s (%s, %s): %zu ticks after %zu warm-up, path %s (%zu poses, back "
      "and forth)\n",
      b.tool.c_str(), b.scene.c_str(), b.scheme, b.storage, b.ticks, b.warmup, b.path_name.c_str(),
      b.poses);
  std::printf("  tick      p50 %.0f ns, p90 %.0f, p99 %.0f, p99.9 %.0f, max %.0f, mean %.1f\n",
              s.p50, s.p90, s.p99, s.p999, s.max, s.mean);
  std::printf("  contacts  %zu points, %.2f in contact on average, touching in %.1f%% of ticks\n",
              b.points, b.in_contact_mean, 100.0 * b.touching);
  std::printf("  clock     %.0f ns per pair of reads (included in the figures)\n", b.clock_ns);
  if (b.window)
    std::printf(
        "  maps      %.1f MiB in a %lldx%lldx%lld window (the whole scene's: %.1f MiB, "
        "%.1fx)\n",
        b.model_mib, static_cast<long long>(b.window->grid().dims[0]),
        static_cast<long long>(b.window->grid().dims[1]),
        static_cast<long long>(b.window->grid().dims[2]), b.whole_mib,
        b.model_mib > 0.0 ? b.whole_mib / b.model_mib : 0.0);
  else
    std::printf("  maps      %.1f MiB\n", b.model_mib);
  if (b.bare.p50 > 0.0)
    std::printf(
        "  layers    %zu (%s%s): p50 %.2fx, p99 %.2fx the tick without them (%.0f, %.0f ns)\n",
        b.layers, b.first_layer.c_str(), b.layers > 1 ? ", ..." : "", s.p50 / b.bare.p50,
        s.p99 / b.bare.p99, b.bare.p50, b.bare.p99);
}

// The last line: the run as JSON.
void print_bench_json(const BenchResult& b) {
  const Summary& s = b.tick;
  std::printf(
      "{\"scene\":%s,\"tool\":%s,\"scheme\":\"%s\",\"storage\":\"%s\",\"path\":%s,"
      "\"ticks\":%zu,\"warmup\":%zu,\"tick_ns_p50\":%.0f,\"tick_ns_p90\":%.0f,"
      "\"tick_ns_p99\":%.0f,\"tick_ns_p999\":%.0f,\"tick_ns_max\":%.0f,\"tick_ns_mean\":%.1f,"
      "\"contacts\":%zu,\"in_contact_mean\":%.3f,\"touching_fraction\":%.4f,"
      "\"clock_pair_ns\":%.0f,\"maps_mib\":%.2f,\"whole_maps_mib\":%.2f,\"layers\":%zu,"
      "\"tick_ns_p50_without_layers\":%.0f,\"tick_ns_p99_without_layers\":%.0f}\n",
      json_string(b.scene).c_str(), json_string(b.tool).c_str(), b.scheme, b.storage,
      json_string(b.path_name).c_str(), b.ticks, b.warmup, s.p50, s.p90, s.p99, s.p999, s.max,
      s.mean, b.points, b.in_contact_mean, b.touching, b.clock_ns, b.model_mib, b.whole_mib,
      b.layers, b.bare.p50, b.bare.p99);
}

}  // namespace

int cmd_bench(const Arguments& argv_in) {
  // --config FILE: the configuration `palp tune --out` chose (or a palpd config's model keys),
  // read as palp run --config reads it; the command line wins.
  Arguments argv = with_model_config(argv_in);
  const std::vector<std::string> assignments = take_repeated(argv, "param");
  std::vector<std::string> valued = kSceneOptions;
  valued.insert(valued.end(),
                {"tool", "ticks", "warmup", "trajectory", "window-mm", "ticks-csv", "config"});
  const Args args(argv, {"help", "quiet"}, valued);
  if (args.has("help")) {
    std::cout << kBenchUsage << kSceneOptionsHelp << kBenchOptions;
    return 0;
  }
  if (!args.positional().empty())
    throw UsageError("bench takes no positional arguments, got '" + args.positional()[0] + "'");
  const auto tool_name = args.get("tool");
  if (!args.get("scene")) throw UsageError("bench needs --scene SCENE");
  if (!tool_name) throw UsageError("bench needs --tool TOOL");
  const std::size_t ticks = parse_count(args, "ticks", 100000);
  const std::size_t warmup = parse_count(args, "warmup", 2000);
  if (ticks == 0) throw UsageError("--ticks needs at least 1");
  const Tool tool = parse_tool(*tool_name);
  const ForceParams params = force_params(model_kind(args), tool, assignments);
  const bool quiet = args.has("quiet");
  (void)scene_options(args);

  // Setup: scene, model, poses (not timed).
  const Scene scene = load_scene_for(args, "bench", quiet);
  BenchResult b;
  const auto trajectory = args.get("trajectory");
  const Trajectory path = trajectory ? read_trajectory_csv(*trajectory)
                                     : default_path(*scene.fields, pad_offset(tool), &b.path_name);
  if (trajectory) b.path_name = *trajectory;
  if (path.empty()) throw InputError("bench: the trajectory has no rows");
  std::shared_ptr<const FieldSampler> fields = scene.fields;
  b.whole_mib = maps_mib(*scene.fields, params);
  if (args.get("window-mm")) {
    const double margin = args.number("window-mm", 0.0);
    if (!(margin >= 0.0 && margin <= 1000.0)) throw UsageError("--window-mm must be 0..1000");
    fields = window_around_path(scene, tool, path, margin);
  }
  const Model model(fields, tool, params, scene.layers);
  b.model_mib = maps_mib(*fields, params);
  // With structure layers, the same ticks without them, for the layers' cost as a ratio.
  if (!model.layers().empty() && params.model == ModelKind::Palp)
    b.bare = summarize(time_ticks(Model(fields, tool, params), path, warmup, ticks).ns);

  // Timing, then the summary.
  b.clock_ns = clock_pair_ns();
  const Timings timings = time_ticks(model, path, warmup, ticks);
  b.tick = summarize(timings.ns);
  if (const auto csv = args.get("ticks-csv")) write_ticks_csv(*csv, timings);
  b.in_contact_mean = timings.in_contact_sum / static_cast<double>(ticks);
  b.touching = static_cast<double>(timings.ticks_touching) / static_cast<double>(ticks);
  b.scene = scene.source;
  b.tool = tool.name;
  b.scheme = to_string(scene.fields->config().gradient);
  b.storage = to_string(scene.fields->config().storage);
  b.poses = path.size();
  b.ticks = ticks;
  b.warmup = warmup;
  b.points = tool.points.size();
  b.layers = model.layers().size();
  if (b.layers > 0) b.first_layer = model.layers().name(0);
  if (fields != scene.fields) b.window = fields.get();
  if (!quiet) print_bench(b);
  print_bench_json(b);
  return 0;
}

}  // namespace palp::cli
