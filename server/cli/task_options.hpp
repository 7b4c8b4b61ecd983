// The task options palp task and palp traj search share: the task's name and --side, --space,
// --interspace, checked the same way for both (docs/tasks.md, "Tasks and their targets").
#pragma once

#include <string>

#include "cli_common/cli.hpp"
#include "training/task.hpp"

namespace palp::cli {

// The task `name` (ptcd, lumbar, femoral) with the options that apply to it. UsageError for an
// unknown task, a side that is not right or left, an option for another task, a space outside
// 1..11 or an interspace outside L1/L2..L5/S1.
training::TaskSpec parse_task_spec(const std::string& name, const Args& args);

}  // namespace palp::cli
