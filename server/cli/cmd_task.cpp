// palp task ptcd|lumbar|femoral --scene SCENE [--landmarks FILE] --trajectory FILE: a training task
// scored offline, deterministically, from a recorded or scripted run (docs/tasks.md).
//   landmarks + spec -> target;  trajectory -> run_offline (palp run's loop) -> samples (LPS)
//   -> trials split by the marks file -> score_trial each -> report.html, cohort CSV, summary
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>

#include "anatomy/landmarks.hpp"
#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "cli/commands.hpp"
#include "cli/offline_run.hpp"
#include "cli/task_options.hpp"
#include "cli_common/cli.hpp"
#include "cli_common/model_setup.hpp"
#include "cli_common/scene_landmarks.hpp"
#include "scene/scene.hpp"
#include "training/cohort_csv.hpp"
#include "training/marks_file.hpp"
#include "training/report.hpp"

namespace palp::cli {
namespace {

using namespace palp::training;

constexpr const char* kTaskUsage =
    R"(usage: palp task ptcd|lumbar|femoral --scene SCENE --trajectory FILE [options]

Scores a training task offline from a recorded or scripted run: the force model runs over the
trajectory exactly as in palp run (one tick per row, deterministic), the skin point (the contact
proxies' mean) and the pressing force of every row go to the patient's LPS frame, the marks file
splits the run into trials, and each trial is scored against the target from the landmarks:
where each mark lies (the asked space, a rib, another space, a spinous process, off the pulse),
its distance to the target, time to mark, peak and mean force, path length and time in contact
(docs/tasks.md). Prints a table; writes DIR/report.html with --out, appends to --csv.
Tasks:
  ptcd       the intercostal space below rib --space (default 9) on --side (default right)
  lumbar     the interspace --interspace (default L3/L4) on the midline
  femoral    the femoral pulse point on --side
Options:
)";

constexpr const char* kTaskOptions =
    R"(  --landmarks FILE        the scene's landmarks JSON (palp landmarks SCENE --out FILE);
                          without it they are found in the scene as palp landmarks finds them
  --trajectory FILE       trajectory CSV: t,px,py,pz,qw,qx,qy,qz (s, mm, scene frame)
  --marks FILE            marks CSV: a header with t (s, the trajectory's clock) and optionally
                          trial (1, 2, ...), one mark a row (docs/tasks.md); none: one trial
                          without marks
  --side right|left       ptcd and femoral (default right)
  --space N               ptcd: the space below rib N, 1..11 (default 9)
  --interspace NAME       lumbar: L1/L2 .. L5/S1 (default L3/L4)
  --tool TOOL             finger:N, twofinger:N or probe:NXxNY (default finger:7)
  --param NAME=VALUE      force parameter override, repeatable (as palp run)
  --pulse-bpm N           the arteries' pulse rate (default 72; 0 = none)
  --out DIR               write DIR/report.html (the page with its charts inline)
  --csv FILE              append one row per trial to the cohort CSV FILE (header when new)
  --session ID            the session's id in the report and CSV (default: DIR's name, else
                          the trajectory's file name)
  --trainee ID            the trainee's id in the report and CSV
  -q, --quiet             print only errors
  -h, --help              show this help
)";

TaskSpec task_spec(const Args& args) {
  if (args.positional().size() != 1)
    throw UsageError("task needs one task: ptcd, lumbar or femoral");
  return parse_task_spec(args.positional()[0], args);
}

struct RunResult {
  std::vector<TrialSample> samples;
  bool pulse = false;  // the scene has an artery layer and it beats
};

// The run's samples in the patient's LPS frame: the device point, the contact proxies' mean
// (the device point out of contact), the pressing force.
RunResult run_samples(const Args& args, const std::vector<std::string>& params, const Tool& tool,
                      const Trajectory& trajectory, bool quiet) {
  const ForceParams force = [&] {
    ForceParams p = force_params(model_kind(args), tool, params);
    if (args.get("pulse-bpm")) set_param(p, "pulse_bpm", args.number("pulse-bpm", 0.0));
    return p;
  }();
  const Scene scene = load_scene_for(args, "task", quiet);
  const Model model(scene.fields, tool, force, scene.layers);
  State state = make_state(model);
  DeviceFilter no_device;
  RunResult result;
  for (std::size_t i = 0; i < scene.layers->size(); ++i)
    result.pulse |= scene.layers->kind(i) == LayerKind::Artery && force.pulse_bpm > 0.0;
  std::vector<TrialSample>& samples = result.samples;
  samples.reserve(trajectory.size());
  run_offline(model, state, trajectory, no_device,
              [&](const TrajectorySample& row, const State& s, const ForceRecord& record) {
                TrialSample sample;
                sample.t = row.t;
                sample.device_point = world_of_scene(scene.grid, row.pose.position);
                Vec3d proxies{};
                for (std::size_t i = 0; i < s.in_contact.size(); ++i)
                  if (s.in_contact[i]) proxies += s.p[i];
                sample.in_contact = record.n_contact > 0;
                sample.skin_point =
                    sample.in_contact
                        ? world_of_scene(scene.grid, proxies * (1.0 / record.n_contact))
                        : sample.device_point;
                sample.normal_force = record.f_normal;
                samples.push_back(sample);
              });
  return result;
}

void print_summary(const Session& session) {
  std::printf("task %s, session %s: %zu trial%s\n", describe(session.target.spec).c_str(),
              session.id.c_str(), session.trials.size(), session.trials.size() == 1 ? "" : "s");
  for (const std::string& note : session.target.notes) std::printf("  note: %s\n", note.c_str());
  std::printf("  %-5s %-5s %-24s %-6s %9s %8s %8s %7s %7s %8s %8s\n", "trial", "marks", "where",
              "target", "dist_mm", "best_mm", "mark_s", "peak_N", "mean_N", "path_mm", "touch_s");
  const auto opt = [](const std::optional<double>& v, const char* format) {
    char text[32] = "-";
    if (v) std::snprintf(text, sizeof text, format, *v);
    return std::string(text);
  };
  for (const Trial& trial : session.trials) {
    const TrialSummary r = summarize(trial);
    std::printf("  %-5d %-5zu %-24s %-6s %9s %8s %8s %7.2f %7.2f %8.1f %8.2f\n", trial.number,
                r.marks, r.where.empty() ? "-" : r.where.c_str(),
                !r.in_target   ? "-"
                : *r.in_target ? "yes"
                               : "no",
                opt(r.distance_mm, "%.1f").c_str(), opt(r.best_distance_mm, "%.1f").c_str(),
                opt(r.time_to_mark_s, "%.2f").c_str(), trial.score.peak_force_n,
                trial.score.mean_force_n, trial.score.path_length_mm,
                trial.score.time_in_contact_s);
  }
}

std::string session_id(const Args& args, const std::string& trajectory_path) {
  if (const auto id = args.get("session")) return *id;
  namespace fs = std::filesystem;
  if (const auto out = args.get("out")) {
    const fs::path dir = fs::path(*out).lexically_normal();
    const std::string name = (dir.has_filename() ? dir : dir.parent_path()).filename().string();
    if (!name.empty() && name != ".") return name;
  }
  return fs::path(trajectory_path).stem().string();
}

}  // namespace

int cmd_task(const Arguments& argv_in) {
  Arguments argv = argv_in;
  const std::vector<std::string> params = take_repeated(argv, "param");
  std::vector<std::string> valued = kSceneOptions;
  valued.insert(valued.end(), {"landmarks", "trajectory", "marks", "side", "space", "interspace",
                               "tool", "pulse-bpm", "out", "csv", "session", "trainee"});
  const Args args(argv, {"help", "quiet"}, valued);
  if (args.has("help")) {
    std::cout << kTaskUsage << kSceneOptionsHelp << kTaskOptions;
    return 0;
  }
  const bool quiet = args.has("quiet");
  // Usage first, then the inputs that can be read quickly, then the (slower) scene.
  const TaskSpec spec = task_spec(args);
  if (!args.get("scene")) throw UsageError("task needs --scene SCENE");
  const auto trajectory_path = args.get("trajectory");
  if (!trajectory_path) throw UsageError("task needs --trajectory FILE");
  const auto landmarks_path = args.get("landmarks");
  const std::string tool_name = args.get("tool").value_or("finger:7");
  const Tool tool = parse_tool(tool_name);
  (void)scene_options(args);

  Session session;
  // The landmarks from the file, else found in the scene as palp landmarks finds them.
  session.landmarks =
      landmarks_path
          ? anatomy::read_landmarks(*landmarks_path)
          : scene_landmarks(*args.get("scene"),
                            args.get("cache-dir").value_or(default_scene_cache_dir()), quiet);
  session.target = resolve_target(spec, session.landmarks);
  const std::vector<MarkRow> marks =
      args.get("marks") ? read_marks_csv(*args.get("marks")) : std::vector<MarkRow>{};
  const Trajectory trajectory = read_trajectory_csv(*trajectory_path);
  session.id = session_id(args, *trajectory_path);
  session.trainee = args.get("trainee").value_or("");
  session.scene = *args.get("scene");
  session.tool = tool_name;

  const RunResult run = run_samples(args, params, tool, trajectory, quiet);
  if (spec.kind == TaskKind::femoral && session.target.pulse_felt != run.pulse) {
    session.target.pulse_felt = run.pulse;
    session.target.notes.push_back(run.pulse
                                       ? "the scene's artery pulses under the point"
                                       : "no artery pulses in this scene: the pulse is not felt");
  }
  session.trials = split_trials(run.samples, marks);
  for (Trial& trial : session.trials)
    trial.score = score_trial(session.target, session.landmarks, trial.samples, trial.marks);

  if (!quiet) print_summary(session);
  if (const auto out = args.get("out")) {
    const std::string page = write_report(*out, session);
    if (!quiet) std::printf("  report %s\n", page.c_str());
  }
  if (const auto csv = args.get("csv")) {
    append_cohort_csv(*csv, session);
    if (!quiet)
      std::printf("  cohort %s: %zu rows appended\n", csv->c_str(), session.trials.size());
  }
  return 0;
}

}  // namespace palp::cli
