// Helpers for the command-line tests of the model commands (run, traj, bench): run the palp
// binary with a private scene cache and capture its output and exit code.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace palp::testing {

struct CliOutcome {
  int exit_code = -1;
  std::string output;
};

// Runs a shell command line as given and collects its stdout and exit status.
inline CliOutcome run_command(const std::string& command) {
  CliOutcome outcome;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return outcome;
  std::array<char, 4096> buffer{};
  while (fgets(buffer.data(), buffer.size(), pipe)) outcome.output += buffer.data();
  const int status = pclose(pipe);
  outcome.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return outcome;
}

// Runs `palp ARGS` with PALP_SCENE_CACHE=cache; stderr goes with stdout unless `stdout_only`.
inline CliOutcome run_palp_cli(const std::string& args, const std::filesystem::path& cache,
                               bool stdout_only = false) {
  return run_command("PALP_SCENE_CACHE='" + cache.string() + "' " + std::string(PALP_CLI_PATH) +
                     " " + args + (stdout_only ? " 2>/dev/null" : " 2>&1") + " </dev/null");
}

inline int count_lines(const std::string& text) {
  int lines = 0;
  for (char c : text) lines += c == '\n';
  return lines;
}

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The last non-empty line of `text`, without its newline.
inline std::string last_line(const std::string& text) {
  std::string t = text;
  while (!t.empty() && t.back() == '\n') t.pop_back();
  const auto nl = t.rfind('\n');
  return nl == std::string::npos ? t : t.substr(nl + 1);
}

// A directory shared by the tests of one binary (scenes prepped once), removed at exit.
inline const std::filesystem::path& shared_cli_dir() {
  struct Dir {
    std::filesystem::path path;
    Dir() {
      path = std::filesystem::temp_directory_path() / ("palp-cli-" + std::to_string(::getpid()));
      std::filesystem::remove_all(path);
      std::filesystem::create_directories(path);
    }
    ~Dir() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
  };
  static const Dir dir;
  return dir.path;
}

}  // namespace palp::testing
