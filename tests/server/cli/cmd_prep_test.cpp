// palp prep interrupted: SIGINT or SIGTERM while a map is being written leaves no temporary file
// and, when prep created the output directory, no directory; the process still ends by the
// signal (a shell sees 130 / 143). The same for a scene that palp bench preps into its cache.
// palp prep --labels: a structure per line with its source; a label map refused in one line.
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

#include "io/ct_io.hpp"
#include "support/cli_test_util.hpp"
#include "support/label_files.hpp"

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

// A 40^3 sphere of 2 mm voxels, and TotalSegmentator's multi-label file of it without its label
// table: liver (5) on 10^3 voxels (8 ml), vertebrae_L1 (31) on 4^3.
TEST(PrepLabelsCli, PrintsAStructurePerLineWithItsSource) {
  const testing::TempDir tmp;
  const fs::path& dir_ = tmp.path();
  const fs::path ct = dir_ / "ct.nii.gz";
  const auto made = testing::run_palp_cli(
      "phantom sphere --out " + ct.string() + " --dims 40x40x40 --spacing 2x2x2", dir_ / "cache");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  const Grid grid = read_ct(ct.string()).grid;
  std::vector<std::uint8_t> values(grid.voxel_count(), 0);
  for (std::int64_t k = 0; k < 10; ++k)
    for (std::int64_t j = 0; j < 10; ++j)
      for (std::int64_t i = 0; i < 10; ++i) {
        values[grid.linear(i + 5, j + 5, k + 5)] = 5;
        if (i < 4 && j < 4 && k < 4) values[grid.linear(i + 25, j + 25, k + 25)] = 31;
      }
  const fs::path seg = dir_ / "seg.nii.gz";
  testing::write_label_nifti(seg.string(), grid, values);
  const std::string prep = "prep " + ct.string() + " --labels " + seg.string() +
                           " --labels-map totalsegmentator --out " + (dir_ / "out").string();
  const auto first = testing::run_palp_cli(prep, dir_ / "cache", /*stdout_only=*/true);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  EXPECT_NE(first.output.find("  bone      64 voxels (1 ml), labels " + seg.string() +
                              " (vertebrae_L1)\n"),
            std::string::npos)
      << first.output;
  EXPECT_NE(
      first.output.find("  liver     1000 voxels (8 ml), labels " + seg.string() + " (liver)\n"),
      std::string::npos)
      << first.output;
  for (const char* file : {"liver.nii.gz", "d_liver.nii.gz", "bone.nii.gz", "prep.json"})
    EXPECT_TRUE(fs::exists(dir_ / "out" / file)) << file;
  const auto second = testing::run_palp_cli(prep, dir_ / "cache", /*stdout_only=*/true);
  EXPECT_NE(second.output.find("(cached"), std::string::npos) << second.output;
  EXPECT_NE(second.output.find("  liver     1000 voxels (8 ml), labels "), std::string::npos)
      << second.output;
}

TEST(PrepLabelsCli, RefusalsAreOneLine) {
  const testing::TempDir tmp;
  const fs::path& dir_ = tmp.path();
  const fs::path out = dir_ / "out";
  const fs::path gone = dir_ / "gone.nii.gz";
  const auto missing = testing::run_palp_cli(
      "prep phantom:sphere --labels " + gone.string() + " --out " + out.string(), dir_ / "cache");
  EXPECT_EQ(missing.exit_code, 1) << missing.output;
  EXPECT_EQ(testing::last_line(missing.output),
            "palp: error: labels: " + gone.string() + ": no such file or directory");
  EXPECT_FALSE(fs::exists(out));
  const auto unknown = testing::run_palp_cli(
      "prep phantom:sphere --labels x.nii.gz --labels-map totalsegmentator-v1 --out d",
      dir_ / "cache");
  EXPECT_EQ(unknown.exit_code, 2) << unknown.output;
  EXPECT_EQ(testing::count_lines(unknown.output), 1) << unknown.output;
  const auto alone = testing::run_palp_cli(
      "prep phantom:sphere --labels-map totalsegmentator --out d", dir_ / "cache");
  EXPECT_EQ(alone.exit_code, 2) << alone.output;
  EXPECT_NE(alone.output.find("--labels-map needs --labels SEG"), std::string::npos);
}

}  // namespace
}  // namespace palp
