// palp traj: every KIND writes a readable trajectory CSV; options that do not apply and other
// usage mistakes are one-line errors with exit code 2.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "scene/trajectory.hpp"
#include "support/cli_test_util.hpp"

namespace {

namespace fs = std::filesystem;
using palp::testing::count_lines;
using palp::testing::read_text;
using palp::testing::run_palp_cli;
using palp::testing::shared_cli_dir;

fs::path cache() {
  return shared_cli_dir() / "cache";
}

TEST(CmdTraj, EveryKindWritesATrajectory) {
  struct Case {
    const char* args;
    std::size_t rows;
  };
  for (const Case& c : {Case{"slide-ramp --scene phantom:cube", 6001},
                        Case{"slide-speed --scene phantom:cube --speeds 10,20 --rate 500", 1501},
                        Case{"press-hold --scene phantom:cube --jitter 0.05 --shift 1", 4501},
                        Case{"ribs --scene phantom:torso --tool probe:9x3 --depth 3", 5751}}) {
    const fs::path out = shared_cli_dir() / "t.csv";
    const auto r = run_palp_cli("traj " + std::string(c.args) + " --out " + out.string(), cache());
    ASSERT_EQ(r.exit_code, 0) << c.args << ": " << r.output;
    EXPECT_NE(r.output.find("wrote"), std::string::npos) << r.output;
    const palp::Trajectory t = palp::read_trajectory_csv(out.string());
    EXPECT_EQ(t.size(), c.rows) << c.args;
    // Deterministic: the same command writes the same bytes.
    const std::string first = read_text(out);
    ASSERT_EQ(
        run_palp_cli("traj " + std::string(c.args) + " --out " + out.string(), cache()).exit_code,
        0);
    EXPECT_EQ(read_text(out), first) << c.args;
  }
}

TEST(CmdTraj, HelpAndUsageMistakes) {
  const auto help = run_palp_cli("traj --help", cache());
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("usage: palp traj"), std::string::npos);
  const std::string out = " --out " + (shared_cli_dir() / "u.csv").string();
  for (const std::string& args : {std::string("traj"), "traj wiggle --scene phantom:cube" + out,
                                  "traj ribs" + out, std::string("traj ribs --scene phantom:cube"),
                                  "traj ribs --scene phantom:torso --speeds 1,2" + out,
                                  "traj slide-ramp --scene phantom:cube --azimuth 3" + out,
                                  "traj slide-ramp --scene phantom:cube --rate 0" + out,
                                  "traj slide-ramp --scene phantom:cube --duration -1" + out,
                                  "traj slide-speed --scene phantom:cube --speeds 10,,3" + out,
                                  "traj press-hold --scene phantom:cube --seed 1.5" + out,
                                  "traj press-hold --scene phantom:cube --side up" + out,
                                  "traj ribs --scene phantom:torso --body-side middle" + out,
                                  "traj ribs --scene phantom:torso --from 2" + out,
                                  "traj ribs --scene phantom:torso --tool hand" + out}) {
    const auto r = run_palp_cli(args, cache());
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.output;
    EXPECT_EQ(count_lines(r.output), 1) << args << ": " << r.output;
  }
}

TEST(CmdTraj, SceneWithoutSkinOnThatSideExitsOne) {
  const auto r = run_palp_cli("traj press-hold --scene phantom:torso --side +z --out " +
                                  (shared_cli_dir() / "v.csv").string(),
                              cache());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("+z"), std::string::npos) << r.output;
}

}  // namespace
