// palp traj KIND --scene SCENE --out FILE: writes one of the paper's device trajectories for a
// scene as a trajectory CSV (see common/scene/trajectory_gen.hpp for the definitions).
//   scene -> anchor on the skin (flat paths) or body axis (ribs) -> generator -> CSV
#include <charconv>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <set>

#include "anatomy/landmarks.hpp"
#include "base/patient_frame.hpp"
#include "cli/commands.hpp"
#include "cli/task_options.hpp"
#include "cli_common/cli.hpp"
#include "cli_common/model_setup.hpp"
#include "scene/search_path.hpp"
#include "scene/trajectory.hpp"
#include "scene/trajectory_gen.hpp"
#include "training/marks_file.hpp"
#include "training/task.hpp"

namespace palp::cli {
namespace {

constexpr const char* kTrajUsage = R"(usage: palp traj KIND --scene SCENE --out FILE [options]

Writes a device trajectory (t,px,py,pz,qw,qx,qy,qz; s, mm, scene frame; one row per tick) for
the scene. The tool's +z points away from the skin; "depth" is how far the pad centre (the
centroid of the tool's contact points) sits below the skin, where D_surf = depth.
KIND:
  slide-ramp    paper Fig. 4a: slide along the surface at constant speed while the indentation
                ramps linearly (default 0 -> 6 mm over 6 s at 10 mm/s, centred on the anchor)
  slide-speed   paper Fig. 4b: press to a fixed depth at rest, slide at piecewise-constant
                speeds (default 3 mm; 10, 40, 10 mm/s for 1 s each), then hold at rest
  press-hold    approach from above, press, optionally shift sideways, hold with an optional
                deterministic jitter (the no-creep experiment; default 4 mm for 3 s)
  ribs          paper Fig. 5a: slide inferior -> superior across the ribs over the lateral /
                anterior chest wall at a fixed depth, the tool aligned with the local skin
                normal (default right side, 30 deg anterior of lateral, 5 mm, 20 mm/s)
  search        a scripted trainee for palp task (docs/tasks.md): the task's target from
                --landmarks; per trial, press in --start mm superior of it (along the skin),
                slide over the skin at --depth to the target moved --miss mm superior, hold
                (the mark, written to --marks), lift; the tool's +z along the local outward
                normal. Defaults: start 25, miss 0, depth 4, approach 10, press-time 1,
                speed 10, hold 1
The flat paths (slide-*, press-hold) work on a plane through an anchor: the skin point hit along
the grid's centre line from --side. Patient sides (anterior, posterior, left, right, superior,
inferior) come from the file's direction matrix, not the voxel order, and slide toward the
patient's left (superior from the left or right). auto: the first of anterior, right, left,
superior, inferior, posterior that reaches skin (the torso's anterior wall; the cube phantom's
top face, its anterior). Grid faces (+x, -x, +y, -y, +z, -z) slide along +y (z faces) or +x.
Options:
)";

constexpr const char* kTrajOptions = R"(  --out FILE              trajectory CSV to write (required)
  --tool TOOL             sets the pad offset (default finger:37: 8 mm; probe: 50 mm)
  --rate HZ               rows per second (default 1000)
  --side S                slide-*, press-hold: auto (default), a patient side (anterior, ...)
                          or a grid face (+x, -x, +y, -y, +z, -z); search: right (default) or
                          left (ptcd, femoral)
  --depth MM              final / fixed depth (slide-ramp 6, slide-speed 3, press-hold 4, ribs 5)
  --depth-start MM        slide-ramp: starting depth (default 0)
  --duration S            slide-ramp: duration (default 6)
  --speed MM_S            slide-ramp: lateral speed (default 10); ribs: (default 20)
  --speeds A,B,...        slide-speed: speeds of the segments (default 10,40,10)
  --segment S             slide-speed: time at each speed (default 1)
  --press-time S          slide-speed 0.5, press-hold 1, ribs 0.5 (press, and ribs' lift)
  --hold S                slide-speed: rest at the end (default 0.5); press-hold: hold (3)
  --approach MM           press-hold, ribs: start this far above the skin (default 2)
  --shift MM              press-hold: lateral shift after the press (default 0)
  --shift-time S          press-hold: duration of the shift (default 0.5)
  --jitter MM             press-hold: uniform jitter amplitude during the hold (default 0)
  --seed N                press-hold: jitter seed (default 1)
  --body-side SIDE        ribs: the patient's right (default) or left
  --azimuth DEG           ribs: ray angle from lateral toward anterior (default 30)
  --from F, --to F        ribs: start and end as fractions of the body axis from its inferior
                          end (default 0.25, 0.75)
  --landmarks FILE        search: the scene's landmarks JSON (palp landmarks SCENE --out FILE)
  --task T                search: ptcd, lumbar or femoral (required)
  --space N               search, ptcd: the space below rib N (default 9)
  --interspace NAME       search, lumbar: L1/L2 .. L5/S1 (default L3/L4)
  --start MM              search: press in this far from the target along the skin, toward the
                          patient's superior (negative: inferior; default 25)
  --miss MM[,MM...]       search: one trial per value, ending this far superior of the target
                          along the skin (default 0: on it; 20: about a rib or space above)
  --marks FILE            search: write the marks CSV (trial,t; one mark per trial, mid-hold)
  -q, --quiet             print only errors
  -h, --help              show this help
)";

// The options each KIND takes (beyond scene, out, tool, rate and the scene options).
const std::map<std::string, std::set<std::string>>& kind_options() {
  static const std::map<std::string, std::set<std::string>> options = {
      {"slide-ramp", {"side", "depth", "depth-start", "duration", "speed"}},
      {"slide-speed", {"side", "depth", "speeds", "segment", "press-time", "hold"}},
      {"press-hold",
       {"side", "depth", "approach", "press-time", "shift", "shift-time", "hold", "jitter",
        "seed"}},
      {"ribs", {"depth", "speed", "press-time", "approach", "body-side", "azimuth", "from", "to"}},
      {"search",
       {"landmarks", "task", "side", "space", "interspace", "start", "miss", "marks", "depth",
        "approach", "press-time", "speed", "hold"}},
  };
  return options;
}

std::vector<std::string> all_valued_options() {
  std::vector<std::string> valued = kSceneOptions;
  valued.insert(valued.end(), {"out", "tool", "rate"});
  std::set<std::string> specific;
  for (const auto& [kind, options] : kind_options())
    specific.insert(options.begin(), options.end());
  valued.insert(valued.end(), specific.begin(), specific.end());
  return valued;
}

// UsageError for an option given that does not apply to `kind`.
void check_options_apply(const Args& args, const std::string& kind) {
  const auto& own = kind_options().at(kind);
  for (const auto& entry : kind_options()) {
    for (const std::string& option : entry.second) {
      if (args.has(option) && !own.count(option))
        throw UsageError("--" + option + " does not apply to traj " + kind);
    }
  }
}

// "A,B,..." for --speeds and --miss.
std::vector<double> parse_numbers(const std::string& text, const char* option) {
  std::vector<double> numbers;
  const char* p = text.data();
  const char* end = text.data() + text.size();
  const std::string error =
      std::string(option) + " needs numbers separated by commas, got '" + text + "'";
  while (true) {
    double v = 0.0;
    const auto [next, ec] = std::from_chars(p, end, v);
    if (ec != std::errc() || next == p || !std::isfinite(v)) throw UsageError(error);
    numbers.push_back(v);
    p = next;
    if (p == end) break;
    if (*p != ',') throw UsageError(error);
    ++p;
  }
  return numbers;
}

std::uint64_t parse_seed(const Args& args) {
  const double seed = args.number("seed", 1.0);
  if (!(seed >= 0.0 && seed <= 9007199254740992.0 && seed == std::floor(seed)))
    throw UsageError("--seed needs a whole number >= 0");
  return static_cast<std::uint64_t>(seed);
}

BodySide parse_body_side(const Args& args) {
  const std::string side = args.get("body-side").value_or("right");
  if (side == "right") return BodySide::Right;
  if (side == "left") return BodySide::Left;
  throw UsageError("--body-side needs right or left, got '" + side + "'");
}

// Everything the command line says about the path, parsed and checked before the scene loads.
struct TrajRequest {
  std::string kind;
  ApproachSide side = ApproachSide::Auto;
  SlideRampSpec ramp;
  SlideSpeedSpec speed;
  PressHoldSpec hold;
  RibsSpec ribs;
  training::TaskSpec task;
  SearchSpec search;
};

// search: the task (as palp task takes it) and the path's timing.
void parse_search(const Args& args, double rate, TrajRequest* r) {
  const auto task = args.get("task");
  if (!task) throw UsageError("traj search needs --task ptcd|lumbar|femoral");
  r->task = parse_task_spec(*task, args);
  if (!args.get("landmarks"))
    throw UsageError("traj search needs --landmarks FILE (palp landmarks SCENE --out FILE)");
  SearchSpec& spec = r->search;
  spec.rate_hz = rate;
  spec.start_mm = args.number("start", spec.start_mm);
  if (const auto miss = args.get("miss")) spec.misses_mm = parse_numbers(*miss, "--miss");
  spec.depth_mm = args.number("depth", spec.depth_mm);
  spec.approach_mm = args.number("approach", spec.approach_mm);
  spec.press_s = args.number("press-time", spec.press_s);
  spec.speed_mm_s = args.number("speed", spec.speed_mm_s);
  spec.hold_s = args.number("hold", spec.hold_s);
  validate(spec);
}

TrajRequest parse_request(const std::string& kind, const Args& args, double rate) {
  TrajRequest r;
  r.kind = kind;
  if (kind == "search") {
    parse_search(args, rate, &r);
    return r;
  }
  r.side = parse_approach_side(args.get("side").value_or("auto"));
  if (kind == "slide-ramp") {
    SlideRampSpec& spec = r.ramp;
    spec.rate_hz = rate;
    spec.duration_s = args.number("duration", spec.duration_s);
    spec.speed_mm_s = args.number("speed", spec.speed_mm_s);
    spec.depth_start_mm = args.number("depth-start", spec.depth_start_mm);
    spec.depth_end_mm = args.number("depth", spec.depth_end_mm);
    validate(spec);
  } else if (kind == "slide-speed") {
    SlideSpeedSpec& spec = r.speed;
    spec.rate_hz = rate;
    spec.depth_mm = args.number("depth", spec.depth_mm);
    spec.press_s = args.number("press-time", spec.press_s);
    if (const auto speeds = args.get("speeds"))
      spec.speeds_mm_s = parse_numbers(*speeds, "--speeds");
    spec.segment_s = args.number("segment", spec.segment_s);
    spec.hold_s = args.number("hold", spec.hold_s);
    validate(spec);
  } else if (kind == "press-hold") {
    PressHoldSpec& spec = r.hold;
    spec.rate_hz = rate;
    spec.approach_mm = args.number("approach", spec.approach_mm);
    spec.depth_mm = args.number("depth", spec.depth_mm);
    spec.press_s = args.number("press-time", spec.press_s);
    spec.shift_mm = args.number("shift", spec.shift_mm);
    spec.shift_s = args.number("shift-time", spec.shift_s);
    spec.hold_s = args.number("hold", spec.hold_s);
    spec.jitter_mm = args.number("jitter", spec.jitter_mm);
    spec.seed = parse_seed(args);
    validate(spec);
  } else {
    RibsSpec& spec = r.ribs;
    spec.rate_hz = rate;
    spec.side = parse_body_side(args);
    spec.azimuth_deg = args.number("azimuth", spec.azimuth_deg);
    spec.from = args.number("from", spec.from);
    spec.to = args.number("to", spec.to);
    spec.speed_mm_s = args.number("speed", spec.speed_mm_s);
    spec.depth_mm = args.number("depth", spec.depth_mm);
    spec.approach_mm = args.number("approach", spec.approach_mm);
    spec.press_s = args.number("press-time", spec.press_s);
    validate(spec);
  }
  return r;
}

// Scene -> anchor (flat paths) or body axis (ribs) -> the generator of the request's kind.
Trajectory generate(const TrajRequest& r, const FieldSampler& fields, double offset,
                    SurfaceAnchor* anchor) {
  if (r.kind == "ribs") return ribs_slide(fields, offset, r.ribs);
  *anchor = find_surface_anchor(fields, r.side);
  if (r.kind == "slide-ramp") return slide_ramp(*anchor, offset, r.ramp);
  if (r.kind == "slide-speed") return slide_speed(*anchor, offset, r.speed);
  return press_hold(*anchor, offset, r.hold);
}

void print_vec(const char* label, const Vec3d& v) {
  std::printf("  %-9s (%.4f, %.4f, %.4f)\n", label, v.x, v.y, v.z);
}

// traj search: landmarks -> the task's target (LPS) -> the path in the scene frame -> CSVs.
int traj_search(const Args& args, const TrajRequest& request, double offset, bool quiet) {
  const anatomy::Landmarks landmarks = anatomy::read_landmarks(*args.get("landmarks"));
  const training::TaskTarget target = training::resolve_target(request.task, landmarks);
  const Scene scene = load_scene_for(args, "traj", quiet);
  const SearchPath path =
      search_path(*scene.fields, {target.point, target.normal}, offset, request.search);
  const std::string out = *args.get("out");
  write_trajectory_csv(out, path.trajectory);
  if (const auto marks = args.get("marks")) {
    std::vector<training::MarkRow> rows;  // one trial per miss, its mark at the hold
    for (std::size_t k = 0; k < path.mark_times_s.size(); ++k)
      rows.push_back({static_cast<int>(k) + 1, path.mark_times_s[k]});
    training::write_marks_csv(*marks, rows);
  }
  if (quiet) return 0;
  std::printf(
      "wrote %s: search for %s, %zu trial%s, %zu rows over %.6g s, pad %g mm below the "
      "device point\n",
      out.c_str(), training::describe(request.task).c_str(), path.mark_times_s.size(),
      path.mark_times_s.size() == 1 ? "" : "s", path.trajectory.size(), path.trajectory.back().t,
      offset);
  print_vec("target", target.point);
  for (std::size_t k = 0; k < path.mark_times_s.size(); ++k) {
    const Vec3d end = world_of_scene(scene.grid, path.end_points_scene[k]);
    std::printf(
        "  trial %zu: miss %g mm, mark at t = %.6g s, end (%.4f, %.4f, %.4f) LPS, "
        "%.1f mm from the target\n",
        k + 1, request.search.misses_mm[k], path.mark_times_s[k], end.x, end.y, end.z,
        norm(end - target.point));
  }
  if (const auto marks = args.get("marks")) std::printf("  marks %s\n", marks->c_str());
  return 0;
}

}  // namespace

int cmd_traj(const Arguments& argv) {
  const Args args(argv, {"help", "quiet"}, all_valued_options());
  if (args.has("help")) {
    std::cout << kTrajUsage << kSceneOptionsHelp << kTrajOptions;
    return 0;
  }
  if (args.positional().size() != 1)
    throw UsageError("traj needs one KIND (slide-ramp, slide-speed, press-hold, ribs, search)");
  const std::string& kind = args.positional()[0];
  if (!kind_options().count(kind))
    throw UsageError("unknown trajectory '" + kind +
                     "' (slide-ramp, slide-speed, press-hold, ribs, search)");
  check_options_apply(args, kind);
  const auto out = args.get("out");
  if (!out) throw UsageError("traj needs --out FILE");
  if (!args.get("scene")) throw UsageError("traj needs --scene SCENE");
  const double offset = pad_offset(parse_tool(args.get("tool").value_or("finger:37")));
  const double rate = args.number("rate", 1000.0);
  const bool quiet = args.has("quiet");
  const TrajRequest request = parse_request(kind, args, rate);
  (void)scene_options(args);

  if (kind == "search") return traj_search(args, request, offset, quiet);
  const Scene scene = load_scene_for(args, "traj", quiet);
  SurfaceAnchor anchor;
  const Trajectory trajectory = generate(request, *scene.fields, offset, &anchor);
  write_trajectory_csv(*out, trajectory);
  if (quiet) return 0;
  std::printf("wrote %s: %s, %zu rows over %.6g s at %g Hz, pad %g mm below the device point\n",
              out->c_str(), kind.c_str(), trajectory.size(), trajectory.back().t, rate, offset);
  if (kind != "ribs") {
    print_vec("anchor", anchor.point);
    print_vec("normal", anchor.normal);
    print_vec("slide", anchor.slide);
  }
  print_vec("first", trajectory.front().pose.position);
  print_vec("last", trajectory.back().pose.position);
  return 0;
}

}  // namespace palp::cli
