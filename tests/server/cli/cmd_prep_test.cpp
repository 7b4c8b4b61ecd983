// palp prep interrupted: SIGINT or SIGTERM while a map is being written leaves no temporary file
// and, when prep created the output directory, no directory; the process still ends by the
// signal (a shell sees 130 / 143).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

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
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (entry.path().filename().string().find(".partial") != std::string::npos) return true;
  }
  return false;
}

TEST_P(PrepInterrupt, MidWriteLeavesNoTemporaryFileAndNoDirectory) {
  const fs::path ct = dir_ / "torso.nii.gz";
  const auto made = testing::run_palp_cli(
      "phantom torso --out " + ct.string() + " --dims 256x256x200", dir_ / "cache");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  const fs::path out = dir_ / "new" / "prep";
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const int null = open("/dev/null", O_WRONLY);
    dup2(null, 1);
    dup2(null, 2);
    execl(PALP_CLI_PATH, PALP_CLI_PATH, "prep", ct.c_str(), "--out", out.c_str(), "--threads", "1",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  // Wait for the first temporary file, then interrupt while it is being written.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  bool seen = false;
  int status = 0;
  while (!seen && std::chrono::steady_clock::now() < deadline) {
    if (waitpid(child, &status, WNOHANG) == child) break;
    seen = holds_partial_file(out);
    if (!seen) std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  ASSERT_TRUE(seen) << "prep finished or stalled before writing a temporary file";
  ASSERT_EQ(kill(child, GetParam()), 0);
  ASSERT_EQ(waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == GetParam()) << status;
  std::string left;
  std::error_code ec;
  for (const auto& entry : fs::recursive_directory_iterator(dir_ / "new", ec)) {
    left.append(" ").append(entry.path().filename().string());
  }
  EXPECT_FALSE(fs::exists(dir_ / "new")) << "prep left behind:" << left;
}

INSTANTIATE_TEST_SUITE_P(Signals, PrepInterrupt, ::testing::Values(SIGINT, SIGTERM));

}  // namespace
}  // namespace palp
