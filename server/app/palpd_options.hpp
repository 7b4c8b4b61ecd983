// palpd's command line: the help text, the options a config file may hold, and the command line
// parsed and checked into the loop's, the server's and the run's settings. Nothing is opened
// here but a replay's recording (its scene, tool, rate, profile and parameters are defaults)
// and --record-dir (made now, so a StartRecording is not refused an hour into a study).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "app/palpd_task.hpp"
#include "cli_common/cli.hpp"
#include "loop/haptic_loop.hpp"
#include "model/force_model.hpp"
#include "net/server.hpp"
#include "rt/recording.hpp"
#include "safety/safety.hpp"

namespace palp::app {

// palpd's whole --help text.
std::string palpd_help();

// The flags and the valued options palpd takes (what a config file may hold as keys).
const std::vector<std::string>& palpd_flags();
const std::vector<std::string>& palpd_valued();

// The command line, checked: every refusal is a UsageError (or an InputError for a replay that
// cannot be read) naming the option, before any device, scene or port is touched.
struct PalpdOptions {
  explicit PalpdOptions(cli::Args command_line) : args(std::move(command_line)) {}

  cli::Args args;  // with a replay's defaults in front of the command line
  std::string device_spec;
  bool quiet = false;
  std::string replay_path;              // replay:FILE: FILE ("" for the other devices)
  std::optional<rt::Recording> replay;  // replay:FILE, read
  Tool tool;
  ForceParams params;
  const DeviceProfile* profile = nullptr;  // --device-profile (run_palpd may choose one)
  rt::LoopConfig loop;
  net::ServerConfig server;
  double duration_s = 0;  // 0: until SIGINT / SIGTERM
  std::string record_dir;
  std::string stats_json;  // "" : none
  app::TaskOptions task;   // --landmarks, --task*: training tasks (palpd_task.hpp)
};

// nullopt: --help was asked for (the caller prints palpd_help()).
std::optional<PalpdOptions> parse_palpd_options(cli::Arguments argv);

// A number within [lo, hi], refused with the option's name and its range otherwise: no timeout
// or interval can overflow a clock, no queue be sized by a typo.
double option_within(const cli::Args& args, const std::string& key, double fallback, double lo,
                     double hi);

// A number that must not be negative.
double option_positive(const cli::Args& args, const std::string& key, double fallback);

}  // namespace palp::app
