// palp — the offline command-line tool: synthetic phantoms and CT preprocessing.
//   palp phantom NAME --out FILE        synthetic CT in HU (cube, sphere, torso)
//   palp prep INPUT --out DIR           masks and signed distance maps (spec "Files")
// Errors print one line on stderr and exit non-zero: 1 for failures, 2 for usage mistakes.
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <iostream>
#include <map>
#include <new>
#include <optional>
#include <string>
#include <vector>

#include "base/batch_memory.hpp"
#include "base/errors.hpp"
#include "cli/commands.hpp"
#include "prep/output_guard.hpp"

namespace palp {
namespace {

constexpr const char* kMainUsage = R"(usage: palp <command> [options]

Commands:
  phantom NAME --out FILE   write a synthetic CT in HU (cube, sphere, torso)
  prep INPUT --out DIR      CT -> body and bone masks and signed distance maps
  run --scene S --tool T --trajectory F --out F
                            offline force model run, one tick per trajectory row
  traj KIND --scene S --out FILE
                            the paper's trajectories (slide-ramp, slide-speed, press-hold, ribs)
  bench --scene S --tool T --ticks N
                            time the tick in-process; last line JSON
  probe HOST:PORT           observe a running palpd: frames/s, delivery, latency, stats
  ctl HOST:PORT ACTION      a lab's console for palpd: record start|stop, set, tool, pause,
                            resume, recentre, status
  tune --scene S --tool T --rate HZ
                            the cheapest configuration that feels the same, as a config file
  task ptcd|lumbar|femoral --scene S --landmarks F --trajectory F
                            a training task scored offline: report page, cohort CSV
  landmarks SCENE --out FILE.json
                            the anatomical landmarks of a scan (vertebrae, ribs, crests, ...)
  version                   print the version

Run `palp <command> --help` for the options of a command.
)";

int dispatch(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << kMainUsage;
    return 2;
  }
  const std::string command = argv[1];
  const std::vector<std::string> rest(argv + 2, argv + argc);
  if (command == "-h" || command == "--help" || command == "help") {
    std::cout << kMainUsage;
    return 0;
  }
  if (command == "version" || command == "--version") {
    std::cout << "palp " << PALP_VERSION << '\n';
    return 0;
  }
  const std::map<std::string, std::function<int(const cli::Arguments&)>> commands = {
      {"phantom", cli::cmd_phantom}, {"prep", cli::cmd_prep},
      {"run", cli::cmd_run},         {"traj", cli::cmd_traj},
      {"bench", cli::cmd_bench},     {"probe", cli::cmd_probe},
      {"ctl", cli::cmd_ctl},         {"tune", cli::cmd_tune},
      {"task", cli::cmd_task},       {"landmarks", cli::cmd_landmarks},
  };
  const auto it = commands.find(command);
  if (it == commands.end()) throw UsageError("unknown command '" + command + "' (try palp --help)");
  return it->second(rest);
}

}  // namespace
}  // namespace palp

int main(int argc, char** argv) {
  // Ctrl-C or SIGTERM during a prep (palp prep, or a scene prepped into the cache by run, traj
  // or bench) leaves no temporary file and no directory it created; otherwise they act as ever.
  palp::install_prep_interrupt_cleanup();
  palp::keep_freed_memory_for_reuse();  // a batch command: freed masks serve the next stage
  try {
    return palp::dispatch(argc, argv);
  } catch (const palp::UsageError& e) {
    std::fprintf(stderr, "palp: %s\n", e.what());
    return 2;
  } catch (const palp::Error& e) {
    std::fprintf(stderr, "palp: error: %s\n", e.what());
    return 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "palp: error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palp: error: %s\n", e.what());
    return 1;
  }
}
