// palpd's run: the options (palpd_options.hpp) -> the device, with its force limits -> the scene,
// the tuning, the model and the device's placement -> the loop, the server and its bridges ->
// wait for the end -> stop, report and --stats-json.
#pragma once

#include "app/palpd_options.hpp"

namespace palp::app {

// Runs palpd until --duration, SIGINT / SIGTERM or the device's end (a replay, a trajectory);
// returns the exit code (0). Errors throw (UsageError, InputError, Error), told by main.
// Blocks SIGINT and SIGTERM in the calling thread (they are awaited with sigtimedwait) and
// ignores SIGPIPE.
int run_palpd(PalpdOptions& o);

}  // namespace palp::app
