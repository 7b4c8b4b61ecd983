// palp run --scene SCENE --tool TOOL --trajectory FILE --out FILE: the offline, deterministic
// run of the spec: one tick per trajectory row, one force CSV row per tick.
//   trajectory row (t, pose) -> run_offline (tick, device profile filters) -> force CSV row
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>

#include "cli/commands.hpp"
#include "cli/offline_run.hpp"
#include "cli_common/cli.hpp"
#include "cli_common/config_file.hpp"
#include "cli_common/model_setup.hpp"
#include "model/force_model.hpp"
#include "safety/safety.hpp"
#include "scene/trajectory.hpp"

namespace palp::cli {
namespace {

constexpr const char* kRunUsage =
    R"(usage: palp run --scene SCENE --tool TOOL --trajectory FILE --out FILE [options]

Runs the force model offline: one tick per trajectory row, in order, deterministically (the same
inputs give a byte-identical output). Writes a force CSV with the columns
  t,fx,fy,fz,tx,ty,tz,n_contact,ux,uy,uz,f_normal,f_lateral,depth,status,safety
(N, N·mm about the device point, mm; f_normal and f_lateral are means over the points in contact
of the pressing force and of the friction force in the skin's tangent plane; depth the mean
D_surf; status the tick's bits, safety the device filters' bits).
Options:
)";

constexpr const char* kRunOptions =
    R"(  --tool TOOL             finger:N (N = 1, 7, 19, 37), twofinger:N or probe:NXxNY (required)
  --trajectory FILE       trajectory CSV: t,px,py,pz,qw,qx,qy,qz (s, mm, scene frame)
  --out FILE              force CSV to write
  --param NAME=VALUE      force parameter override, repeatable (ranges enforced):
                            c [0, 20] mm/N, k [0, 5] N/mm, bone_fmax [0, 60] N,
                            bone_flip [0, 10], bone_enabled 0|1, bone_mode 0 (printed) | 1
                            (robust), bone_k [0, 100] N/mm, grad_epsilon and
                            direction_epsilon (0, 0.1], model 0 (paper) | 1 (palp);
                            palp only: mu [0, 2], skin_fmax [1, 200] N,
                            bone_fade_mm [0, 30] mm, bone_reach_mm [1, 20] mm,
                            bone_along_normal 0|1; structure layers (palp only):
                            pulse_bpm [0, 240], pulse_systolic_mmHg, pulse_diastolic_mmHg,
                            pulse_vessel_mm, pad_mm, organ_reach_mm, organ_k1, organ_k3,
                            organ_fmax (docs/force_model.md "Structures as layers")
  --pulse-bpm N           the arteries' pulse rate (default 72; 0 = no pulse), the same as
                          --param pulse_bpm=N
  --device-profile NAME   apply a device's limits after the model: touch, falcon,
                          phantom-premium, omega (default: none, the model's own output)
  --config FILE           TOML with scene, tool, model, scheme, storage, param (e.g. what
                          palp tune --out writes); the command line wins
  -q, --quiet             print only errors
  -h, --help              show this help
)";

void print_usage() {
  std::cout << kRunUsage << kSceneOptionsHelp << kRunOptions;
}

struct RunSummary {
  std::size_t ticks_in_contact = 0;
  double contact_points_sum = 0.0;
  double max_force = 0.0;
  double max_force_t = 0.0;
  std::uint32_t status_seen = 0;
};

void print_summary(const RunSummary& s, std::size_t ticks, const std::string& out, double seconds) {
  std::printf("run %s: %zu ticks\n", out.c_str(), ticks);
  std::printf(
      "  contact   %zu of %zu ticks, %.2f points on average when touching\n", s.ticks_in_contact,
      ticks,
      s.ticks_in_contact ? s.contact_points_sum / static_cast<double>(s.ticks_in_contact) : 0.0);
  std::printf("  force     max |f| %.4g N at t = %.6g s\n", s.max_force, s.max_force_t);
  if (s.status_seen & kTickOutsideGrid) std::printf("  note      some points left the grid\n");
  std::printf("  time      %.3f s (%.2f us a tick, with file output)\n", seconds,
              ticks ? 1e6 * seconds / static_cast<double>(ticks) : 0.0);
}

}  // namespace

int cmd_run(const Arguments& argv_in) {
  // --config FILE: the model keys of a palpd config or a `palp tune --out` file, before the
  // command line's options (which win).
  Arguments argv = with_model_config(argv_in);
  const std::vector<std::string> assignments = take_repeated(argv, "param");
  std::vector<std::string> valued = kSceneOptions;
  valued.insert(valued.end(),
                {"tool", "trajectory", "out", "device-profile", "config", "pulse-bpm"});
  const Args args(argv, {"help", "quiet"}, valued);
  if (args.has("help")) {
    print_usage();
    return 0;
  }
  if (!args.positional().empty())
    throw UsageError("run takes no positional arguments, got '" + args.positional()[0] + "'");
  const auto tool_name = args.get("tool");
  const auto trajectory_path = args.get("trajectory");
  const auto out = args.get("out");
  if (!args.get("scene")) throw UsageError("run needs --scene SCENE");
  if (!tool_name) throw UsageError("run needs --tool TOOL");
  if (!trajectory_path) throw UsageError("run needs --trajectory FILE");
  if (!out) throw UsageError("run needs --out FILE");
  const bool quiet = args.has("quiet");
  // Everything a usage mistake can be is checked before the (slower) scene load.
  const Tool tool = parse_tool(*tool_name);
  ForceParams params = force_params(model_kind(args), tool, assignments);
  if (args.get("pulse-bpm")) set_param(params, "pulse_bpm", args.number("pulse-bpm", 0.0));
  DeviceFilter filter;
  if (const auto profile = args.get("device-profile")) filter.profile = &device_profile(*profile);
  (void)scene_options(args);

  const Trajectory trajectory = read_trajectory_csv(*trajectory_path);
  const Scene scene = load_scene_for(args, "run", quiet);
  const Model model(scene.fields, tool, params, scene.layers);
  State state = make_state(model);
  ForceCsvWriter writer(*out);

  const auto start = std::chrono::steady_clock::now();
  RunSummary summary;
  summary.status_seen =
      run_offline(model, state, trajectory, filter,
                  [&](const TrajectorySample& row, const State&, const ForceRecord& record) {
                    writer.write(record);
                    if (record.n_contact > 0) {
                      ++summary.ticks_in_contact;
                      summary.contact_points_sum += record.n_contact;
                    }
                    if (const double f = norm(record.force); f > summary.max_force) {
                      summary.max_force = f;
                      summary.max_force_t = row.t;
                    }
                  });
  writer.finish();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!quiet) print_summary(summary, trajectory.size(), *out, seconds);
  return 0;
}

}  // namespace palp::cli
