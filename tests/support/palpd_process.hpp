// palpd as a background process for end-to-end tests (needs PALPD_PATH, the binary): start it
// with its output in a log file, learn its port from the log, wait for its closing line, or stop
// it (SIGTERM) once a test is done with it instead of waiting out its --duration.
#pragma once

#include <signal.h>
#include <sys/types.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <filesystem>
#include <regex>
#include <string>
#include <thread>

#include "support/cli_test_util.hpp"

namespace palp::testing {

// Starts palpd in the background with its output in `log`; returns the port it listens on
// (0 when it did not come up within the timeout). Its process id goes to `log` + ".pid".
inline int start_palpd(const std::string& args, const std::filesystem::path& log) {
  const std::string command = "PALP_SCENE_CACHE='" + (shared_cli_dir() / "cache").string() + "' " +
                              PALPD_PATH + " " + args + " >'" + log.string() +
                              "' 2>&1 </dev/null & echo $! >'" + log.string() + ".pid'";
  if (std::system(command.c_str()) != 0) return 0;
  const std::regex listening("listening on 127\\.0\\.0\\.1:([0-9]+)");
  for (int i = 0; i < 600; ++i) {
    std::smatch match;
    const std::string text = read_text(log);
    if (std::regex_search(text, match, listening)) return std::stoi(match[1]);
    if (text.find("error") != std::string::npos) return 0;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return 0;
}

// Waits for palpd's closing summary line in `log`.
inline bool wait_palpd_exit(const std::filesystem::path& log) {
  for (int i = 0; i < 600; ++i) {
    if (read_text(log).find(" ticks, ") != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return false;
}

// Asks the palpd that start_palpd(…, log) started to stop (SIGTERM, as a lab's service manager
// would) and waits for its closing summary; false when there is no such process or no summary.
inline bool stop_palpd(const std::filesystem::path& log) {
  std::ifstream pid_file(log.string() + ".pid");
  long pid = 0;
  if (!(pid_file >> pid) || pid <= 1) return false;
  if (::kill(static_cast<pid_t>(pid), SIGTERM) != 0) return false;
  return wait_palpd_exit(log);
}

}  // namespace palp::testing
