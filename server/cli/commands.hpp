// The palp subcommands. Each takes the arguments after its name and returns the exit code;
// errors are thrown as palp::Error (exit 1) or palp::UsageError (exit 2) and printed by main.
#pragma once

#include "cli_common/cli.hpp"

namespace palp::cli {

int cmd_phantom(const Arguments& args);  // cmd_phantom.cpp
int cmd_prep(const Arguments& args);     // cmd_prep.cpp
int cmd_run(const Arguments& args);      // cmd_run.cpp
int cmd_traj(const Arguments& args);     // cmd_traj.cpp
int cmd_bench(const Arguments& args);    // cmd_bench.cpp
int cmd_probe(const Arguments& args);    // cmd_probe.cpp (palpd observer)
int cmd_ctl(const Arguments& args);      // cmd_ctl.cpp (palpd controller console)
int cmd_tune(const Arguments& args);     // cmd_tune.cpp (the cheapest configuration that feels the same)
int cmd_task(const Arguments& args);     // cmd_task.cpp (a training task scored offline)
int cmd_landmarks(const Arguments& args);  // cmd_landmarks.cpp (the anatomical landmarks of a scan)

}  // namespace palp::cli
