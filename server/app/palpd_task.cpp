// palpd's training tasks: see palpd_task.hpp.
#include "app/palpd_task.hpp"

#include <cstdio>
#include <ctime>
#include <filesystem>
#include <utility>
#include <vector>

#include "base/errors.hpp"
#include "cli_common/scene_landmarks.hpp"
#include "rt/recording.hpp"
#include "scene/scene.hpp"
#include "training/cohort_csv.hpp"
#include "training/report.hpp"

namespace palp::app {

TaskOptions task_options(const cli::Args& args, const std::string& record_dir) {
  TaskOptions o;
  o.report_dir = args.get("task-report-dir").value_or(record_dir);
  if (const auto path = args.get("landmarks")) {
    o.landmarks_path = *path;
    o.landmarks = anatomy::read_landmarks(*path);
    (void)net::wire_landmarks(*o.landmarks, Grid{});  // too many points for the clients: refused now
  }
  const bool details =
      args.get("task-side") || args.get("task-space") || args.get("task-interspace");
  const auto kind_text = args.get("task");
  if (!kind_text) {
    if (details) throw UsageError("--task-side, --task-space and --task-interspace need --task");
    return o;
  }
  training::TaskSpec spec;
  const auto kind = training::parse_task_kind(*kind_text);
  if (!kind) throw UsageError("--task must be ptcd, lumbar or femoral, got '" + *kind_text + "'");
  spec.kind = *kind;
  if (const auto side = args.get("task-side")) {
    const auto parsed = anatomy::parse_side(*side);
    if (!parsed) throw UsageError("--task-side must be right or left, got '" + *side + "'");
    spec.side = *parsed;
  }
  spec.space = static_cast<int>(args.number("task-space", spec.space));
  spec.interspace = args.get("task-interspace").value_or(spec.interspace);
  try {
    training::validate(spec);
  } catch (const Error& e) {
    throw UsageError(std::string("--task: ") + e.what());
  }
  // No --landmarks: found in the scene as palp landmarks finds them (a second or two on a CT,
  // once, before the loop starts).
  if (!o.landmarks) {
    const auto scene = args.get("scene");
    if (!scene) throw UsageError("--task needs --landmarks FILE or --scene SCENE");
    o.landmarks = cli::scene_landmarks(
        *scene, args.get("cache-dir").value_or(default_scene_cache_dir()), args.has("quiet"));
    o.landmarks_path = "found in " + *scene;
    (void)net::wire_landmarks(*o.landmarks, Grid{});
  }
  o.task = spec;
  return o;
}

namespace {

std::string utc_stamp() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y%m%d-%H%M%S", &utc);
  return text;
}

// The recorded marks of the recording a replay plays, as the ticks it reaches them at.
std::vector<std::uint64_t> replay_ticks(const std::string& replay_path) {
  std::vector<std::uint64_t> ticks;
  const std::string path = rt::marks_path_for(replay_path);
  if (replay_path.empty() || !std::filesystem::exists(path)) return ticks;
  for (const rt::RecordedMark& m : rt::read_recording_marks(path)) ticks.push_back(m.tick);
  return ticks;
}

}  // namespace

std::unique_ptr<net::TaskSession> task_beside(TaskOptions o, const Grid& grid,
                                              PalpdControl& control, net::Server& server,
                                              const std::string& replay_path, bool quiet) {
  if (!o.landmarks) return nullptr;
  net::TaskSetup setup;
  const double sample_rate_hz = setup.sample_rate_hz;
  setup.landmarks = std::move(o.landmarks);
  setup.landmarks_source = o.landmarks_path;
  setup.grid = grid;
  const std::string dir = o.report_dir;
  setup.write_report = [dir](const net::TaskSessionRecord& r) { return write_task_report(r, dir); };
  setup.on_mark = [&control](std::uint64_t seq, std::int64_t t_ns) {
    control.note_mark(seq, t_ns);
  };
  auto task = std::make_unique<net::TaskSession>(std::move(setup));
  const std::vector<std::uint64_t> ticks = replay_ticks(replay_path);
  if (!ticks.empty() && !quiet)
    std::printf("palpd: the replay's %zu recorded marks will mark again\n", ticks.size());
  task->replay_marks(ticks);
  if (o.task) {
    const std::string failure = task->start(*o.task);
    if (!failure.empty())
      throw UsageError("--task " + training::describe(*o.task) + ": " + failure);
    if (!quiet) std::printf("palpd: task %s running\n", task->view().task.c_str());
  }
  net::TaskSession* raw = task.get();
  // every snapshot: the session keeps samples at its own rate and watches the mark button
  server.add_snapshot_tap([raw](const rt::Snapshot& s) { raw->offer(s); }, sample_rate_hz);
  control.set_task(raw);
  return task;
}

// The session report (training/report.hpp): DIR/task-STAMP/report.html, and the session's
// trials appended to the cohort CSV DIR/cohort.csv.
std::string write_task_report(const net::TaskSessionRecord& record, const std::string& dir) {
  training::Session session;
  session.id = "task-" + utc_stamp();
  session.target = record.target;
  if (record.landmarks) {
    session.landmarks = *record.landmarks;
    session.scene = record.landmarks->scene;
  }
  for (const net::ScoredTrial& t : record.trials)
    session.trials.push_back({t.number, t.samples, t.marks, t.score});
  const std::string page =
      training::write_report((std::filesystem::path(dir) / session.id).string(), session);
  training::append_cohort_csv((std::filesystem::path(dir) / "cohort.csv").string(), session);
  return page;
}

}  // namespace palp::app
