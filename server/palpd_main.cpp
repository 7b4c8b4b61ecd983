// palpd — the real-time haptic server.
//   scene + tool + parameters -> Model; DEVICE -> HapticLoop (its own thread, --rate HZ) ->
//   snapshot ring -> Server (Asio io thread) -> clients; record ring -> Recorder (--record FILE)
// Configuration: a TOML file (--config FILE) whose keys are the long option names; the command
// line overrides it. Errors print one line and exit 1 (failure) or 2 (usage).
//
// parse (app/palpd_options: the config file's arguments, then the command line's) -> build and
// run (app/palpd_run: device, scene, model, loop, server; until the end) -> report (there too).
#include <cstdio>
#include <exception>
#include <iostream>
#include <map>
#include <optional>
#include <string>

#include "app/palpd_options.hpp"
#include "app/palpd_run.hpp"
#include "app/rt_options.hpp"
#include "base/errors.hpp"
#include "cli_common/cli.hpp"
#include "cli_common/config_file.hpp"

namespace palp {
namespace {

// palpd with its arguments: the config file's first, then the command line's (which win).
int run_configured(cli::Arguments argv) {
  std::optional<app::PalpdOptions> options = app::parse_palpd_options(std::move(argv));
  if (!options) {
    std::cout << app::palpd_help();
    return 0;
  }
  return app::run_palpd(*options);
}

int run(const cli::Arguments& argv_in) {
  // --help whatever the config file holds (it is the first thing to reach for when it is wrong)
  for (const std::string& a : argv_in)
    if (a == "--help" || a == "-h") {
      std::cout << app::palpd_help();
      return 0;
    }
  const auto config = cli::config_path(argv_in);
  std::map<std::string, int> lines;
  cli::Arguments from_config;
  if (config)
    from_config = cli::config_arguments(*config, app::palpd_flags(),
                                        app::with_rt_options(app::palpd_valued()), &lines);
  try {
    from_config.insert(from_config.end(), argv_in.begin(), argv_in.end());
    return run_configured(std::move(from_config));
  } catch (const UsageError& e) {
    if (!config) throw;
    throw UsageError(cli::config_error(e.what(), *config, lines, argv_in));
  }
}

}  // namespace
}  // namespace palp

int main(int argc, char** argv) {
  try {
    return palp::run(palp::cli::Arguments(argv + 1, argv + argc));
  } catch (const palp::UsageError& e) {
    std::fprintf(stderr, "palpd: %s\n", e.what());
    return 2;
  } catch (const palp::Error& e) {
    std::fprintf(stderr, "palpd: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palpd: error: %s\n", e.what());
    return 1;
  }
}
