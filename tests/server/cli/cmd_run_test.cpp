// palp run as a user meets it: byte-identical repeated runs, the analytic press force on the
// cube, device profiles, and one-line errors with the documented exit codes.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "model/force_model.hpp"
#include "support/cli_test_util.hpp"

namespace {

namespace fs = std::filesystem;
using palp::testing::count_lines;
using palp::testing::last_line;
using palp::testing::read_text;
using palp::testing::run_palp_cli;
using palp::testing::shared_cli_dir;

fs::path dir() {
  return shared_cli_dir();
}
fs::path cache() {
  return shared_cli_dir() / "cache";
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream s(line);
  std::string field;
  while (std::getline(s, field, ',')) out.push_back(field);
  return out;
}

// A press-hold trajectory on the cube (4 mm, short hold), written once.
std::string cube_press() {
  const fs::path path = dir() / "press.csv";
  if (!fs::exists(path)) {
    const auto made = run_palp_cli(
        "traj press-hold --scene phantom:cube --hold 0.2 --out " + path.string(), cache());
    EXPECT_EQ(made.exit_code, 0) << made.output;
  }
  return path.string();
}

std::string run_args(const std::string& trajectory, const fs::path& out) {
  return "run --scene phantom:cube --tool finger:37 --trajectory " + trajectory + " --out " +
         out.string();
}

TEST(CmdRun, TwoRunsAreByteIdentical) {
  const fs::path ramp = dir() / "ramp.csv";
  ASSERT_EQ(run_palp_cli("traj slide-ramp --scene phantom:cube --duration 2 --out " + ramp.string(),
                         cache())
                .exit_code,
            0);
  for (const char* extra : {"", " --scheme central --storage int16 --param c=1.5"}) {
    const auto a = run_palp_cli(run_args(ramp.string(), dir() / "a.csv") + extra, cache());
    const auto b = run_palp_cli(run_args(ramp.string(), dir() / "b.csv") + extra, cache());
    ASSERT_EQ(a.exit_code, 0) << a.output;
    ASSERT_EQ(b.exit_code, 0) << b.output;
    const std::string first = read_text(dir() / "a.csv");
    EXPECT_EQ(count_lines(first), 2002) << "header + one row per trajectory row";
    EXPECT_EQ(first, read_text(dir() / "b.csv"));
    EXPECT_EQ(first.rfind("t,fx,fy,fz,tx,ty,tz,n_contact,ux,uy,uz,", 0), 0u);
  }
}

TEST(CmdRun, PressOnTheCubeGivesTheAnalyticForce) {
  // --model paper: the printed law; the default (palp): the saturated law (0.00003 % lower here).
  for (const char* model : {" --model paper", ""}) {
    SCOPED_TRACE(model);
    const auto out = run_palp_cli(run_args(cube_press(), dir() / "f.csv") + model, cache());
    ASSERT_EQ(out.exit_code, 0) << out.output;
    EXPECT_NE(out.output.find("ticks"), std::string::npos);
    const std::vector<std::string> row = split(last_line(read_text(dir() / "f.csv")));
    ASSERT_EQ(row.size(), 16u);
    const double f = *model ? palp::surface_force(4.0) : palp::saturated_surface_force(4.0, 30.0);
    EXPECT_NEAR(std::stod(row[3]), f, 1e-9);     // fz
    EXPECT_EQ(row[7], "37");                     // n_contact
    EXPECT_NEAR(std::stod(row[11]), f, 1e-9);    // f_normal
    EXPECT_NEAR(std::stod(row[13]), 4.0, 1e-6);  // depth
    EXPECT_EQ(row[15], "0");                     // no safety filter
  }
}

TEST(CmdRun, DeviceProfileLimitsTheForce) {
  const fs::path deep = dir() / "deep.csv";
  ASSERT_EQ(run_palp_cli(
                "traj press-hold --scene phantom:cube --depth 9 --hold 0.2 --out " + deep.string(),
                cache())
                .exit_code,
            0);
  const fs::path out = dir() / "limited.csv";
  const auto run = run_palp_cli(run_args(deep.string(), out) + " --device-profile falcon", cache());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const std::vector<std::string> row = split(last_line(read_text(out)));
  EXPECT_NEAR(std::stod(row[3]), 8.0, 1e-9);  // the Falcon's 8 N, not f_s(9) = 13.3 N
  EXPECT_NE(row[15], "0");
}

TEST(CmdRun, HelpAndUsageMistakes) {
  const auto help = run_palp_cli("run --help", cache());
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("usage: palp run"), std::string::npos);
  const std::string t = cube_press();
  const std::string out = (dir() / "x.csv").string();
  for (const std::string& args :
       {std::string("run"), "run --scene phantom:cube --tool finger:37 --trajectory " + t,
        "run --scene phantom:cube --trajectory " + t + " --out " + out,
        "run --tool finger:37 --trajectory " + t + " --out " + out,
        "run --scene phantom:cube --tool finger:5 --trajectory " + t + " --out " + out,
        "run --scene phantom:cube --tool finger:37 --trajectory " + t + " --out " + out +
            " --param c",
        "run --scene phantom:cube --tool finger:37 --trajectory " + t + " --out " + out +
            " --param frob=1",
        "run --scene phantom:cube --tool finger:37 --trajectory " + t + " --out " + out +
            " --param k=-1",
        "run --scene phantom:cube --tool finger:37 --trajectory " + t + " --out " + out +
            " --device-profile toaster",
        "run --scene phantom:cube --tool finger:37 --trajectory " + t + " --out " + out +
            " --scheme fancy",
        "run extra --scene phantom:cube --tool finger:37 --trajectory " + t + " --out " + out}) {
    const auto r = run_palp_cli(args, cache());
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.output;
    EXPECT_EQ(count_lines(r.output), 1) << args << ": " << r.output;
  }
}

TEST(CmdRun, BadTrajectoriesAndScenesExitOne) {
  const fs::path bad = dir() / "bad.csv";
  {
    std::ofstream f(bad);
    f << "t,px,py,pz,qw,qx,qy,qz\n0,1,2,3,1,0,0,0\n0.001,1,2,nan,1,0,0,0\n";
  }
  const std::string out = (dir() / "y.csv").string();
  const auto r = run_palp_cli(
      "run --scene phantom:cube --tool finger:37 --trajectory " + bad.string() + " --out " + out,
      cache());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(count_lines(r.output), 1) << r.output;
  EXPECT_NE(r.output.find("bad.csv:3:"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out));
  const auto s =
      run_palp_cli("run --scene " + (dir() / "nowhere").string() +
                       " --tool finger:37 --trajectory " + cube_press() + " --out " + out,
                   cache());
  EXPECT_EQ(s.exit_code, 1);
  EXPECT_NE(s.output.find("nowhere"), std::string::npos) << s.output;
}

}  // namespace
