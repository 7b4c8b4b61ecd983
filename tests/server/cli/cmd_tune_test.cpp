// palp tune: writes a configuration that palp run --config reads (and its CSV), says which
// candidate it chose and why the others lost; usage mistakes are one-line errors with exit 2.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "support/cli_test_util.hpp"

namespace {

namespace fs = std::filesystem;
using palp::testing::count_lines;
using palp::testing::run_palp_cli;
using palp::testing::shared_cli_dir;

fs::path cache() {
  return shared_cli_dir() / "cache";
}

std::string read(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

TEST(CmdTune, WritesAConfigThatPalpRunReads) {
  const fs::path dir = shared_cli_dir() / "tune";
  fs::remove_all(dir);
  const fs::path out = dir / "cube.toml";
  const auto r = run_palp_cli(
      "tune --scene phantom:cube --tool finger:7 --rate 1000 --repeats 1 "
      "--out " +
          out.string(),
      cache(), /*stdout_only=*/true);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("chosen: finger:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("reference, accepted"), std::string::npos) << r.output;
  const std::string config = read(out);
  for (const char* key : {"scene = \"phantom:cube\"", "tool = \"finger:", "model = \"palp\"",
                          "scheme = \"", "storage = \"", "rate = 1000", "# chosen: "})
    EXPECT_NE(config.find(key), std::string::npos) << key << " in\n" << config;
  // 18 candidates (finger:7 and finger:1, 3 schemes x 3 storages) and the header.
  EXPECT_EQ(count_lines(read(dir / "cube.csv")), 19) << read(dir / "cube.csv");

  const fs::path traj = dir / "hold.csv";
  ASSERT_EQ(run_palp_cli("traj press-hold --scene phantom:cube --out " + traj.string(), cache())
                .exit_code,
            0);
  const auto run = run_palp_cli("run --config " + out.string() + " --trajectory " + traj.string() +
                                    " --out " + (dir / "f.csv").string(),
                                cache());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_TRUE(fs::exists(dir / "f.csv"));

  // palp bench --config times the configuration the file names.
  const auto bench = run_palp_cli("bench --config " + out.string() + " --ticks 200 -q", cache(),
                                  /*stdout_only=*/true);
  ASSERT_EQ(bench.exit_code, 0) << bench.output;
  const std::string json = palp::testing::last_line(bench.output);
  for (const std::string key : {"scheme", "storage"}) {
    const std::size_t in_config = config.find(key + " = \"");
    ASSERT_NE(in_config, std::string::npos) << key;
    const std::size_t from = in_config + key.size() + 4;
    const std::string value = config.substr(from, config.find('"', from) - from);
    std::string want = "\"";
    want.append(key).append("\":\"").append(value).append("\"");
    EXPECT_NE(json.find(want), std::string::npos) << want << " in " << json;
  }
}

TEST(CmdTune, HelpAndUsageMistakes) {
  const auto help = run_palp_cli("tune --help", cache());
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("usage: palp tune"), std::string::npos);
  for (const char* args :
       {"tune", "tune --scene phantom:cube --tool finger:7",
        "tune --scene phantom:cube --rate 1000",
        "tune --scene phantom:cube --tool finger:7 --rate 0",
        "tune --scene phantom:cube --tool finger:7 --rate 1000 --repeats 0",
        "tune --scene phantom:cube --tool finger:7 --rate 1000 --tolerance-rel 2",
        "tune --scene phantom:cube --tool finger:5 --rate 1000"}) {
    const auto r = run_palp_cli(args, cache());
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.output;
    EXPECT_EQ(count_lines(r.output), 1) << args << ": " << r.output;
  }
}

}  // namespace
