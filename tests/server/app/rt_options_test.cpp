// palpd's timing options (server/app/rt_options.cpp) and palp probe --check-rate
// (server/console/check_rate.cpp) end to end: usage errors, a session in each wake-up mode whose
// --stats-json says which it ran and what it spent, the check's verdict and its hand-off. No
// assertion depends on how well this machine keeps time: only on the reports being there and
// agreeing.
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>
#include <string>

#include "support/cli_test_util.hpp"
#include "support/palpd_process.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using testing::read_text;
using testing::run_palp_cli;
using testing::shared_cli_dir;
using testing::start_palpd;
using testing::wait_palpd_exit;

testing::CliOutcome run_palpd(const std::string& args) {
  return testing::run_command(std::string(PALPD_PATH) + " " + args + " 2>&1 </dev/null");
}

double number_after(const std::string& text, const std::string& key) {
  std::smatch m;
  if (!std::regex_search(text, m, std::regex("\"" + key + "\":([-0-9.e+]+)"))) return -1;
  return std::stod(m[1]);
}

TEST(RtOptions, BadValuesAreUsageErrors) {
  const std::string base = "--scene phantom:sphere --device sim --no-realtime ";
  struct Case {
    const char* args;
    const char* says;
  };
  for (const Case& c : {Case{"--wake spin", "--wake must be sleep or hybrid"},
                        Case{"--wake sleep --spin-us 50", "--spin-us applies to --wake hybrid"},
                        Case{"--spin-us -1", "--spin-us must be in"},
                        Case{"--rt-cpu 4096", "--rt-cpu must be a CPU number"},
                        Case{"--rt-cpu 1.5", "--rt-cpu must be a CPU number"},
                        Case{"--rt-cpu 0 --net-cpu 0", "--net-cpu must differ from --rt-cpu"},
                        Case{"--net-wake sometimes", "--net-wake must be event, event-every"}}) {
    const auto r = run_palpd(base + c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << ": " << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << c.args << ": " << r.output;
  }
  const auto help = run_palpd("--help");
  for (const char* option :
       {"--wake MODE", "--spin-us US", "--rt-cpu N", "--net-cpu N", "--net-wake MODE"})
    EXPECT_NE(help.output.find(option), std::string::npos) << option;
}

// One palpd session; its --stats-json.
std::string session(const std::string& name, const std::string& options, std::string* log_text) {
  const fs::path dir = shared_cli_dir() / ("rt-" + name);
  fs::create_directories(dir);
  const fs::path log = dir / "palpd.log", stats = dir / "stats.json";
  fs::remove(stats);
  const int port = start_palpd(
      "--scene phantom:sphere --device sim --tool finger:7 --port 0 "
      "--rate 2000 --duration 2.5 --stats-json " +
          stats.string() + " " + options,
      log);
  EXPECT_GT(port, 0) << read_text(log);
  if (port > 0) {
    const auto probe =
        run_palp_cli("probe 127.0.0.1:" + std::to_string(port) + " --duration 1.3", dir / "cache");
    EXPECT_EQ(probe.exit_code, 0) << probe.output;
    // Stats (about once a second) carry the wake-up mode and the spin window
    const std::string mode = options.find("sleep") == std::string::npos ? "hybrid" : "sleep";
    EXPECT_NE(probe.output.find("wake-up   " + mode + ", spin window"), std::string::npos)
        << probe.output;
  }
  EXPECT_TRUE(wait_palpd_exit(log)) << read_text(log);
  *log_text = read_text(log);
  return read_text(stats);
}

TEST(RtOptions, EachWakeUpModeRunsAndReportsWhatItSpent) {
  std::string log;
  const std::string sleep = session("sleep", "--wake sleep --net-wake poll", &log);
  EXPECT_NE(log.find("wake-up: sleep"), std::string::npos) << log;
  EXPECT_NE(sleep.find("\"mode\":\"sleep\""), std::string::npos) << sleep;
  EXPECT_EQ(number_after(sleep, "spin_cpu_fraction"), 0.0) << sleep;
  EXPECT_EQ(number_after(sleep, "spin_window_us"), 0.0) << sleep;
  EXPECT_EQ(number_after(sleep, "net_signals"), 0.0) << sleep;  // poll: the loop never signals
  EXPECT_GT(number_after(sleep, "net_wakeups"), 0.0) << sleep;

  const std::string hybrid = session("hybrid", "--rt-cpu 0", &log);
  EXPECT_NE(log.find("loop thread pinned to CPU 0"), std::string::npos) << log;
  EXPECT_NE(log.find("wake-up: hybrid, spin window"), std::string::npos) << log;
  EXPECT_NE(hybrid.find("\"mode\":\"hybrid\""), std::string::npos) << hybrid;
  // the window is within its bounds: 10 us .. half of the 500 us period
  EXPECT_GE(number_after(hybrid, "spin_window_us"), 10.0) << hybrid;
  EXPECT_LE(number_after(hybrid, "spin_window_us"), 250.0) << hybrid;
  EXPECT_GE(number_after(hybrid, "spin_cpu_fraction"), 0.0) << hybrid;
  EXPECT_LE(number_after(hybrid, "spin_cpu_fraction"), 0.5) << hybrid;
  EXPECT_GT(number_after(hybrid, "net_signals"), 0.0) << hybrid;  // the eventfd hand-off ran
  EXPECT_GT(number_after(hybrid, "process_cpu_s"), 0.0) << hybrid;
  EXPECT_NE(hybrid.find("\"latency_counts\":["), std::string::npos) << hybrid;
}

TEST(CheckRate, GivesAVerdictThatAgreesWithItsExitStatus) {
  const auto r = run_palp_cli("probe --check-rate 2000 --duration 0.3", shared_cli_dir() / "cache");
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;
  const std::string json = testing::last_line(r.output);
  EXPECT_NE(json.find(r.exit_code == 0 ? "\"holds\":true" : "\"holds\":false"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find(r.exit_code == 0 ? "verdict: this machine holds 2000 Hz"
                                           : "verdict: this machine cannot hold 2000 Hz"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("  wake-up    p50"), std::string::npos) << r.output;
  // 0.3 s at 2 kHz: about 600 deadlines, each counted once (ticks + missed)
  const double deadlines = number_after(json, "deadlines");
  EXPECT_GE(deadlines, 590);
  EXPECT_LE(deadlines, 601);
  // a bound nothing can miss by: always holds
  const auto lax = run_palp_cli("probe --check-rate 500 --duration 0.2 --wake sleep --max-miss 100",
                                shared_cli_dir() / "cache");
  EXPECT_TRUE(lax.exit_code == 0 || lax.output.find("ticks past the watchdog") != std::string::npos)
      << lax.output;
  EXPECT_NE(lax.output.find("\"wake\":\"sleep\""), std::string::npos) << lax.output;
}

// Its stand-in tick hands off to a network thread as palpd's loop does (issue 41): with no
// client no eventfd write at all, with a client taking 100 frames a second about one write per
// frame, with --net-wake event-every one a tick. Counts only; any verdict is accepted.
TEST(CheckRate, HandsItsTicksOffAsPalpdsLoopDoes) {
  const fs::path cache = shared_cli_dir() / "cache";
  const std::string base = "probe --check-rate 2000 --duration 0.3 --max-miss 100 -q ";
  const auto ticks = [](const std::string& json) {
    return number_after(json, "deadlines") - number_after(json, "missed");
  };
  const auto none = run_palp_cli(base, cache);
  ASSERT_TRUE(none.exit_code == 0 || none.exit_code == 1) << none.output;
  EXPECT_EQ(number_after(none.output, "net_signals"), 0) << none.output;
  const auto every = run_palp_cli(base + "--net-wake event-every", cache);
  ASSERT_TRUE(every.exit_code == 0 || every.exit_code == 1) << every.output;
  EXPECT_GT(ticks(every.output), 500);
  EXPECT_EQ(number_after(every.output, "net_signals"), ticks(every.output)) << every.output;
  const auto station = run_palp_cli(base + "--clients 1 --client-hz 100", cache);
  ASSERT_TRUE(station.exit_code == 0 || station.exit_code == 1) << station.output;
  EXPECT_GE(number_after(station.output, "net_signals"), 1) << station.output;
  EXPECT_LE(number_after(station.output, "net_signals"), 60) << station.output;  // 30 frames
  EXPECT_EQ(run_palp_cli(base + "--clients -1", cache).exit_code, 2);
  EXPECT_EQ(run_palp_cli(base + "--clients 1.5", cache).exit_code, 2);
  EXPECT_EQ(run_palp_cli(base + "--client-hz 5000", cache).exit_code, 2);  // above the rate
  EXPECT_EQ(run_palp_cli(base + "--net-wake sometimes", cache).exit_code, 2);
}

TEST(CheckRate, UsageErrors) {
  const fs::path cache = shared_cli_dir() / "cache";
  EXPECT_EQ(run_palp_cli("probe --check-rate 0", cache).exit_code, 2);
  EXPECT_EQ(run_palp_cli("probe --check-rate 1000 127.0.0.1:7400", cache).exit_code, 2);
  EXPECT_EQ(run_palp_cli("probe --check-rate 1000 --wake spin", cache).exit_code, 2);
  EXPECT_EQ(run_palp_cli("probe --check-rate 1000 --rt-cpu 4096", cache).exit_code, 2);
  const auto help = run_palp_cli("probe --check-rate 1000 --help", cache);
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("--work-us US"), std::string::npos) << help.output;
  EXPECT_NE(run_palp_cli("probe --help", cache).output.find("--check-rate HZ"), std::string::npos);
}

}  // namespace
}  // namespace palp
