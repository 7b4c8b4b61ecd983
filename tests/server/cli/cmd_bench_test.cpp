// palp bench: human lines, then one JSON line last on stdout with the promised keys; usage
// mistakes are one-line errors with exit code 2.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "support/cli_test_util.hpp"

namespace {

namespace fs = std::filesystem;
using palp::testing::count_lines;
using palp::testing::last_line;
using palp::testing::run_palp_cli;
using palp::testing::shared_cli_dir;

fs::path cache() {
  return shared_cli_dir() / "cache";
}

TEST(CmdBench, PrintsAJsonLineLast) {
  for (const char* args : {"bench --scene phantom:cube --tool finger:37 --ticks 3000",
                           "bench --scene phantom:torso --tool finger:7 --ticks 2000 --warmup 10 "
                           "--scheme precomputed --storage interleaved --param k=0.3"}) {
    const auto r = run_palp_cli(args, cache(), /*stdout_only=*/true);
    ASSERT_EQ(r.exit_code, 0) << args << ": " << r.output;
    EXPECT_GE(count_lines(r.output), 2) << "human lines first: " << r.output;
    const auto json = nlohmann::json::parse(last_line(r.output));
    for (const char* key : {"tick_ns_p50", "tick_ns_p90", "tick_ns_p99", "tick_ns_p999",
                            "tick_ns_max", "tick_ns_mean", "contacts", "in_contact_mean", "ticks",
                            "scene", "tool", "scheme", "storage", "path"}) {
      EXPECT_TRUE(json.contains(key)) << key << " in " << r.output;
    }
    EXPECT_LE(json["tick_ns_p50"].get<double>(), json["tick_ns_p99"].get<double>());
    EXPECT_LE(json["tick_ns_p99"].get<double>(), json["tick_ns_max"].get<double>());
    EXPECT_GT(json["tick_ns_p50"].get<double>(), 0.0);
    EXPECT_GT(json["in_contact_mean"].get<double>(), 0.5) << "the default path touches the skin";
  }
}

TEST(CmdBench, TimesAGivenTrajectory) {
  const fs::path traj = shared_cli_dir() / "hold.csv";
  ASSERT_EQ(run_palp_cli("traj press-hold --scene phantom:cube --out " + traj.string(), cache())
                .exit_code,
            0);
  const auto r = run_palp_cli(
      "bench --scene phantom:cube --tool probe:3x3 --ticks 1000 -q --trajectory " + traj.string(),
      cache(), true);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(count_lines(r.output), 1) << "--quiet: only the JSON line";
  const auto json = nlohmann::json::parse(last_line(r.output));
  EXPECT_EQ(json["contacts"], 9);
  EXPECT_EQ(json["ticks"], 1000);
}

TEST(CmdBench, WritesEveryTimedTickAsCsv) {
  // --ticks-csv: one row per timed tick, pose indices running back and forth over the path,
  // the JSON's contact mean recomputed from the rows.
  const fs::path csv = shared_cli_dir() / "bench_ticks.csv";
  const auto r = run_palp_cli(
      "bench --scene phantom:cube --tool finger:7 --ticks 500 --warmup 0 "
      "-q --ticks-csv " +
          csv.string(),
      cache(), true);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto json = nlohmann::json::parse(last_line(r.output));
  std::ifstream in(csv);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  EXPECT_EQ(line, "tick,pose,ns,status,in_contact");
  int rows = 0;
  double contacts = 0;
  long long max_ns = 0;
  while (std::getline(in, line)) {
    long long tick = -1, pose = -1, ns = -1, in_contact = -1;
    unsigned status = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lld,%lld,%lld,%u,%lld", &tick, &pose, &ns, &status,
                          &in_contact),
              5)
        << line;
    EXPECT_EQ(tick, rows);
    if (rows == 0) {
      EXPECT_EQ(pose, 0);  // no warm-up: the path's first pose
    }
    EXPECT_GE(ns, 0);
    EXPECT_GE(in_contact, 0);
    EXPECT_LE(in_contact, 7);
    contacts += static_cast<double>(in_contact);
    max_ns = std::max(max_ns, ns);
    ++rows;
  }
  EXPECT_EQ(rows, 500);
  EXPECT_NEAR(contacts / rows, json["in_contact_mean"].get<double>(), 1e-3);
  EXPECT_EQ(static_cast<double>(max_ns), json["tick_ns_max"].get<double>());
}

// --config FILE: the file `palp tune --out` writes (written here by hand, with what tune would
// choose on a small scene) is what gets timed: its scene, tool, scheme, storage and param, its
// rate read and not used; the command line wins; a key bench has no use for is refused.
TEST(CmdBench, BenchesTheConfigurationOfATuneFile) {
  const fs::path dir = shared_cli_dir() / "bench_config";
  fs::create_directories(dir);
  const fs::path config = dir / "tuned.toml";
  std::ofstream(config) << "# chosen: finger:7 analytic int16\n"
                           "scene = \"phantom:cube\"\ntool = \"finger:7\"\nmodel = \"palp\"\n"
                           "scheme = \"analytic\"\nstorage = \"int16\"\nrate = 4000\n"
                           "param = [\"k=0.3\"]\n";
  const auto r = run_palp_cli("bench --config " + config.string() + " --ticks 500 -q", cache(),
                              /*stdout_only=*/true);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto json = nlohmann::json::parse(last_line(r.output));
  EXPECT_EQ(json["scene"], "phantom:cube");
  EXPECT_EQ(json["tool"], "finger:7");
  EXPECT_EQ(json["contacts"], 7);
  EXPECT_EQ(json["scheme"], "analytic");
  EXPECT_EQ(json["storage"], "int16");
  EXPECT_EQ(json["ticks"], 500);

  const auto wins = run_palp_cli(
      "bench --config=" + config.string() + " --storage float32 --tool finger:1 --ticks 500 -q",
      cache(), true);
  ASSERT_EQ(wins.exit_code, 0) << wins.output;
  const auto j2 = nlohmann::json::parse(last_line(wins.output));
  EXPECT_EQ(j2["storage"], "float32");
  EXPECT_EQ(j2["scheme"], "analytic");
  EXPECT_EQ(j2["tool"], "finger:1");

  const fs::path palpd_only = dir / "palpd.toml";
  std::ofstream(palpd_only) << "scene = \"phantom:cube\"\ntool = \"finger:7\"\nport = 7000\n";
  const auto refused = run_palp_cli("bench --config " + palpd_only.string(), cache());
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_NE(refused.output.find("key 'port': unknown key"), std::string::npos) << refused.output;
  fs::remove_all(dir);
}

TEST(CmdBench, HelpAndUsageMistakes) {
  const auto help = run_palp_cli("bench --help", cache());
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("usage: palp bench"), std::string::npos);
  for (const char* args : {"bench", "bench --scene phantom:cube", "bench --tool finger:37",
                           "bench --scene phantom:cube --tool finger:37 --ticks 0",
                           "bench --scene phantom:cube --tool finger:37 --ticks 1.5",
                           "bench --scene phantom:cube --tool finger:37 --warmup -1",
                           "bench --scene phantom:cube --tool finger:37 --storage fp8",
                           "bench --scene phantom:cube --tool finger:37 --param c=abc"}) {
    const auto r = run_palp_cli(args, cache());
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.output;
    EXPECT_EQ(count_lines(r.output), 1) << args << ": " << r.output;
  }
}

}  // namespace
