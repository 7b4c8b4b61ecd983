// palpd's training tasks (issue 40): --landmarks, --task and its options read and checked at
// start, the TaskSession on the grid's placement fed by the server's snapshot tap, its marks kept
// with a running recording (and a replay's recorded marks played back), and the session report
// written when the session ends.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "anatomy/landmarks.hpp"
#include "app/palpd_control.hpp"
#include "base/volume.hpp"
#include "cli_common/cli.hpp"
#include "net/server.hpp"
#include "net/task_session.hpp"
#include "training/task.hpp"

namespace palp::app {

// What --landmarks and --task* ask for, checked (UsageError naming the option; InputError for a
// landmarks file that cannot be read), before the scene is loaded.
struct TaskOptions {
  std::optional<anatomy::Landmarks> landmarks;
  std::string landmarks_path;
  std::optional<training::TaskSpec> task;  // started with palpd
  std::string report_dir;                  // --task-report-dir, else --record-dir
};
TaskOptions task_options(const cli::Args& args, const std::string& record_dir);

// The session (null without landmarks or a task): tapped on `server`, wired to `control`'s
// recordings, the replay's marks (`replay_path`: the recording a replay plays, "" for none)
// scheduled, the --task started. Throws UsageError when the --task cannot start (the scan does
// not show its target).
std::unique_ptr<net::TaskSession> task_beside(TaskOptions options, const Grid& grid,
                                              PalpdControl& control, net::Server& server,
                                              const std::string& replay_path, bool quiet);

// The one call site of the session report: writes it into `dir` and returns its path.
std::string write_task_report(const net::TaskSessionRecord& record, const std::string& dir);

}  // namespace palp::app
