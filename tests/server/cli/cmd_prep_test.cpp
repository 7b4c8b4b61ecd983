// palp prep interrupted: SIGINT or SIGTERM while a map is being written leaves no temporary file
// and, when prep created the output directory, no directory; the process still ends by the
// signal (a shell sees 130 / 143). The same for a scene that palp bench preps into its cache.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "support/cli_test_util.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;

class PrepInterrupt : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override {
    std::string name = "palp_prep_interrupt_test_";
    name.append(std::to_string(::getpid())).append("_").append(std::to_string(GetParam()));
    dir_ = fs::temp_directory_path() / name;
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

bool holds_partial_file(const fs::path& dir) {
  std::error_code ec;
  for (const auto& entry : fs::recursive_directory_iterator(dir, ec)) {
    if (entry.path().filename().string().find(".partial") != std::string::npos) return true;
  }
  return false;
}

// Runs palp ARGS, interrupts it with `signal` once a temporary file appears under `watch`, and
// returns what is left under `watch` (empty when it does not exist).
std::string interrupt_mid_write(const std::vector<std::string>& args, int signal,
                                const fs::path& watch) {
  const pid_t child = fork();
  if (child < 0) return "fork failed";
  if (child == 0) {
    const int null = open("/dev/null", O_WRONLY);
    dup2(null, 1);
    dup2(null, 2);
    std::vector<char*> argv{const_cast<char*>(PALP_CLI_PATH)};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(PALP_CLI_PATH, argv.data());
    _exit(127);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  bool seen = false;
  int status = 0;
  while (!seen && std::chrono::steady_clock::now() < deadline) {
    if (waitpid(child, &status, WNOHANG) == child) return "exited before a temporary file";
    seen = holds_partial_file(watch);
    if (!seen) std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  kill(child, seen ? signal : SIGKILL);
  waitpid(child, &status, 0);
  if (!seen) return "no temporary file within 120 s";
  if (!WIFSIGNALED(status) || WTERMSIG(status) != signal) return "did not end by the signal";
  std::string left;
  std::error_code ec;
  for (const auto& entry : fs::recursive_directory_iterator(watch, ec))
    left.append(" ").append(entry.path().lexically_relative(watch).string());
  return left;
}

fs::path write_torso(const fs::path& dir) {
  const fs::path ct = dir / "torso.nii.gz";
  const auto made = testing::run_palp_cli(
      "phantom torso --out " + ct.string() + " --dims 256x256x200", dir / "cache");
  EXPECT_EQ(made.exit_code, 0) << made.output;
  return ct;
}

TEST_P(PrepInterrupt, MidWriteLeavesNoTemporaryFileAndNoDirectory) {
  const fs::path ct = write_torso(dir_);
  const fs::path out = dir_ / "new" / "prep";
  EXPECT_EQ(interrupt_mid_write({"prep", ct.string(), "--out", out.string(), "--threads", "1"},
                                GetParam(), dir_ / "new"),
            "");
  EXPECT_FALSE(fs::exists(dir_ / "new"));
}

TEST_P(PrepInterrupt, SceneCachePrepLeavesNothingInTheCache) {
  const fs::path ct = write_torso(dir_);
  const fs::path cache = dir_ / "scenes";
  fs::create_directories(cache);
  EXPECT_EQ(interrupt_mid_write({"bench", "--scene", ct.string(), "--tool", "finger:1", "--ticks",
                                 "1", "--cache-dir", cache.string()},
                                GetParam(), cache),
            "");
}

INSTANTIATE_TEST_SUITE_P(Signals, PrepInterrupt, ::testing::Values(SIGINT, SIGTERM));

}  // namespace
}  // namespace palp
