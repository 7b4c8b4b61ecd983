// `palp ctl HOST:PORT task ...`: the training task's actions as Commands, and its status as
// palp ctl prints it.
#pragma once

#include <string>
#include <vector>

#include "palp.pb.h"

namespace palp::cli {

struct CtlTaskAction {
  std::vector<v1::Command> commands;
  std::vector<std::string> what;  // one line per command, for people
  bool observer = false;          // task status: needs no controller (no token), as the instructor
};

// The words after "task": start KIND [--side S] [--space N] [--interspace NAME], mark, next,
// stop, status. UsageError for anything else.
CtlTaskAction parse_ctl_task(const std::vector<std::string>& words);

// The status as lines ("task       ptcd right 9/10, running, trial 2, 1 mark", ...).
std::string task_status_text(const v1::TaskStatus& status);

}  // namespace palp::cli
