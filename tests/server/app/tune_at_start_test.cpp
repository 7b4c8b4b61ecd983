// palpd --tune end to end: the first start tunes (within its budget) and caches the choice, a
// second start takes it from the cache; the choice reaches clients in Stats (palp probe); a
// budget too small runs the defaults and says so; usage mistakes are refused.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "support/cli_test_util.hpp"
#include "support/palpd_process.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using testing::read_text;
using testing::run_palp_cli;
using testing::shared_cli_dir;

testing::CliOutcome run_palpd(const std::string& args) {
  const std::string command = "PALP_SCENE_CACHE='" + (shared_cli_dir() / "cache").string() + "' " +
                              PALPD_PATH + " " + args + " 2>&1 </dev/null";
  return testing::run_command(command);
}

// One test, so its steps run in order (the cache is what they share).
TEST(TuneAtStart, TunesOnceCachesReportsAndKeepsItsBudget) {
  const fs::path tune_cache = shared_cli_dir() / "cache" / "tune";
  fs::remove_all(tune_cache);
  const std::string base = "--scene phantom:sphere --device sim --no-realtime --port 0 ";

  // First start: tuned, written to the cache, the choice in Stats.
  const fs::path log = shared_cli_dir() / "palpd_tune.log";
  const int port = testing::start_palpd(base + "--tool finger:1 --tune --duration 3", log);
  ASSERT_GT(port, 0) << read_text(log);
  const auto probe = run_palp_cli("probe 127.0.0.1:" + std::to_string(port) + " --duration 1.5",
                                  shared_cli_dir() / "cache");
  EXPECT_EQ(probe.exit_code, 0) << probe.output;
  EXPECT_NE(probe.output.find("  tuning    finger:1 "), std::string::npos) << probe.output;
  EXPECT_NE(probe.output.find("tuned in "), std::string::npos) << probe.output;
  ASSERT_TRUE(testing::wait_palpd_exit(log)) << read_text(log);
  const std::string first = read_text(log);
  EXPECT_NE(first.find("palpd: --tune: tuning finger:1 at 1000 Hz"), std::string::npos) << first;
  ASSERT_TRUE(fs::is_directory(tune_cache)) << first;
  int entries = 0;
  for (const auto& e : fs::directory_iterator(tune_cache))
    entries += e.path().extension() == ".toml";
  EXPECT_EQ(entries, 1);

  // Second start: from the cache, the same choice, no tuning.
  const auto second = run_palpd(base + "--tool finger:1 --tune --duration 0.2");
  EXPECT_EQ(second.exit_code, 0) << second.output;
  EXPECT_NE(second.output.find("palpd: --tune: finger:1 "), std::string::npos) << second.output;
  EXPECT_NE(second.output.find(", cached ("), std::string::npos) << second.output;
  EXPECT_EQ(second.output.find("tuning finger:1 at"), std::string::npos) << second.output;
  // A damaged entry is ignored, tuned again and rewritten.
  fs::path entry;
  for (const auto& e : fs::directory_iterator(tune_cache))
    if (e.path().extension() == ".toml") entry = e.path();
  { std::ofstream(entry) << "tool = [not toml"; }
  const auto damaged = run_palpd(base + "--tool finger:1 --tune --duration 0.2");
  EXPECT_EQ(damaged.exit_code, 0) << damaged.output;
  EXPECT_NE(damaged.output.find("ignoring the unreadable cache"), std::string::npos)
      << damaged.output;
  EXPECT_NE(damaged.output.find("tuning finger:1 at 1000 Hz"), std::string::npos) << damaged.output;
  EXPECT_NE(read_text(entry).find("tool = \"finger:1\""), std::string::npos) << read_text(entry);
  // Another rate is another entry (tuned, not taken from the 1 kHz one).
  const auto other = run_palpd(base + "--tool finger:1 --rate 2000 --tune --duration 0.2");
  EXPECT_EQ(other.exit_code, 0) << other.output;
  EXPECT_NE(other.output.find("tuning finger:1 at 2000 Hz"), std::string::npos) << other.output;

  // A budget too small: the defaults, said so, palpd runs; nothing cached.
  const auto tight =
      run_palpd(base + "--tool finger:7 --tune --tune-budget-s 0.001 --duration 0.2");
  EXPECT_EQ(tight.exit_code, 0) << tight.output;
  EXPECT_NE(tight.output.find("over the time budget of 0.001 s"), std::string::npos)
      << tight.output;
  EXPECT_NE(tight.output.find("running the defaults (finger:7 precomputed interleaved)"),
            std::string::npos)
      << tight.output;
  entries = 0;
  for (const auto& e : fs::directory_iterator(tune_cache))
    entries += e.path().extension() == ".toml";
  EXPECT_EQ(entries, 2);

  // Usage mistakes.
  EXPECT_EQ(run_palpd(base + "--tune-budget-s 5 --duration 0.1").exit_code, 2);
  EXPECT_EQ(run_palpd(base + "--tune --tune-budget-s 0 --duration 0.1").exit_code, 2);
  EXPECT_EQ(run_palpd(base + "--tune --tune-budget-s 1e9 --duration 0.1").exit_code, 2);
}

}  // namespace
}  // namespace palp
