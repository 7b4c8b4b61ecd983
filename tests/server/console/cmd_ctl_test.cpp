// palp ctl against a real palpd (sim device): a study's actions from one console, each printing
// what palpd answered and what changed, refusals exiting 1, and recordings never overwritten; a
// token is never sent in clear text to another machine.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <string>

#include "rt/recording.hpp"
#include "support/cli_test_util.hpp"
#include "support/net_test_client.hpp"
#include "support/outside_address.hpp"
#include "support/palpd_process.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using testing::read_text;
using testing::run_palp_cli;
using testing::shared_cli_dir;

TEST(CmdCtl, ATrialFromOneConsole) {
  const fs::path dir = shared_cli_dir() / "ctl";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path log = dir / "palpd.log", rec = dir / "recordings";  // made by palpd
  const int port = testing::start_palpd(
      // 20 s: the trial's ten console commands took 8.5 s on a loaded machine, past an 8 s palpd
      "--scene phantom:sphere --device sim --port 0 --duration 20 "
      "--no-realtime --record-dir " +
          rec.string(),
      log);
  ASSERT_GT(port, 0) << read_text(log);
  const std::string at = "ctl 127.0.0.1:" + std::to_string(port) + " ";
  const fs::path cache = dir / "cache";

  auto r = run_palp_cli(at + "status", cache);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("tool       finger:37"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("model palp, c 2, k 0.4"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("state      running, not recording"), std::string::npos) << r.output;

  r = run_palp_cli(at + "set c=1.5 k=0.3", cache);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("set c=1.5: ok"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("changed: c 2 -> 1.5"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("changed: k 0.4 -> 0.3"), std::string::npos) << r.output;

  r = run_palp_cli(at + "set k=50", cache);  // beyond its physical range
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("set k=50: refused: force parameter k must be in [0, 5] N/mm"),
            std::string::npos)
      << r.output;

  r = run_palp_cli(at + "record start trial1", cache);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("now: running, recording"), std::string::npos) << r.output;
  r = run_palp_cli(at + "record stop", cache);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::is_regular_file(rec / "trial1"));
  EXPECT_TRUE(fs::is_regular_file(rec / "trial1.csv"));
  // the recording notes who started it, when, and the parameters in force
  const rt::Recording recording = rt::read_recording((rec / "trial1").string());
  EXPECT_NE(recording.metadata.at("started-by").find("controller 'palp-ctl'"), std::string::npos);
  EXPECT_EQ(recording.metadata.at("param.c"), "1.5");
  EXPECT_EQ(recording.metadata.at("started-at").size(), 20u);
  const auto size = fs::file_size(rec / "trial1");
  r = run_palp_cli(at + "record start trial1", cache);  // exists: refused, not overwritten
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("already exists"), std::string::npos) << r.output;
  EXPECT_EQ(fs::file_size(rec / "trial1"), size);

  r = run_palp_cli(at + "pause", cache);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("now: paused"), std::string::npos) << r.output;
  r = run_palp_cli(at + "tool finger:7", cache);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("changed: tool finger:37 -> finger:7"), std::string::npos) << r.output;
  r = run_palp_cli(at + "resume", cache);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("now: running"), std::string::npos) << r.output;
  EXPECT_TRUE(testing::stop_palpd(log)) << read_text(log);
}

// The pulse rate from the console: palp ctl pulse -> palpd's loop -> every frame's pulse_bpm
// (and SceneInfo's, which ctl prints as the change); out of [0, 240] refused.
TEST(CmdCtl, ThePulseRateReachesTheFrames) {
  const fs::path dir = shared_cli_dir() / "ctl-pulse";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path log = dir / "palpd.log";
  const int port = testing::start_palpd(
      "--scene phantom:sphere --device sim --port 0 --duration 20 --no-realtime --pulse-bpm 60",
      log);
  ASSERT_GT(port, 0) << read_text(log);
  const std::string at = "ctl 127.0.0.1:" + std::to_string(port) + " ";
  const fs::path cache = dir / "cache";
  auto r = run_palp_cli(at + "pulse 90", cache);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("pulse 90: ok"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("changed: pulse_bpm 60 -> 90"), std::string::npos) << r.output;
  r = run_palp_cli(at + "pulse 300", cache);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("pulse 300: refused: pulse_bpm must be in [0, 240]"), std::string::npos)
      << r.output;
  EXPECT_EQ(run_palp_cli(at + "pulse", cache).exit_code, 2);
  EXPECT_EQ(run_palp_cli(at + "pulse fast", cache).exit_code, 2);

  testing::TestClient observer(static_cast<std::uint16_t>(port));
  observer.hello(v1::OBSERVER, "", wire::kProtocolVersion, 0, 50.0);
  v1::ServerMessage m;
  ASSERT_TRUE(observer.wait_for_case(v1::ServerMessage::kFrame, m));
  ASSERT_TRUE(m.frame().has_pulse_bpm());
  EXPECT_EQ(m.frame().pulse_bpm(), 90.0f);
  EXPECT_GE(m.frame().pulse_wave(), 0.0f);
  EXPECT_LE(m.frame().pulse_wave(), 1.0f);
  observer.close();
  EXPECT_TRUE(testing::stop_palpd(log)) << read_text(log);
}

TEST(CmdCtl, UsageMistakesAndNoServer) {
  const fs::path cache = shared_cli_dir() / "cache";
  EXPECT_EQ(run_palp_cli("ctl", cache).exit_code, 2);
  EXPECT_EQ(run_palp_cli("ctl 127.0.0.1:1", cache).exit_code, 2);
  EXPECT_EQ(run_palp_cli("ctl 127.0.0.1:1 dance", cache).exit_code, 2);
  EXPECT_EQ(run_palp_cli("ctl 127.0.0.1:1 set c", cache).exit_code, 2);
  EXPECT_EQ(run_palp_cli("ctl 127.0.0.1:1 record", cache).exit_code, 2);
  EXPECT_EQ(run_palp_cli("ctl 127.0.0.1:1 status --timeout 0", cache).exit_code, 2);
  const auto none = run_palp_cli("ctl 127.0.0.1:1 status --timeout 2", cache);
  EXPECT_EQ(none.exit_code, 1);
  EXPECT_NE(none.output.find("cannot connect"), std::string::npos) << none.output;
  const auto help = run_palp_cli("ctl --help", cache);
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("record start [NAME]"), std::string::npos);
}

// A token never leaves in clear text for another machine: ctl and probe refuse before they
// connect, naming --tls-ca and --tls-pin; palpd would refuse it too, but only after it crossed
// the wire. To loopback (by address or by a name resolving there) they go on, and a client
// certificate without --tls-ca/--tls-pin is refused rather than unused over plain text.
TEST(CmdCtl, ATokenIsNeverSentInClearTextOffLoopback) {
  const fs::path cache = shared_cli_dir() / "cache";
  // 192.0.2.1 (TEST-NET-1, RFC 5737) answers nothing: a client that tried would wait 20 s.
  for (const std::string command :
       {"ctl 192.0.2.1:7400 status --token s3cret --timeout 20",
        "probe 192.0.2.1:7400 --role controller --token s3cret --duration 20"}) {
    const auto started = std::chrono::steady_clock::now();
    const auto r = run_palp_cli(command, cache);
    const double took =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    EXPECT_EQ(r.exit_code, 2) << command << ": " << r.output;
    EXPECT_NE(r.output.find("clear text"), std::string::npos) << command << ": " << r.output;
    EXPECT_NE(r.output.find("--tls-ca"), std::string::npos) << command << ": " << r.output;
    EXPECT_NE(r.output.find("--tls-pin"), std::string::npos) << command << ": " << r.output;
    EXPECT_LT(took, 10.0) << command;
  }
  // A listener on this machine's outside address: nothing connects to it at all.
  if (const std::string outside = testing::outside_address(); !outside.empty()) {
    const testing::SilentListener listener;
    const std::string at = outside + ":" + std::to_string(listener.port());
    for (const std::string& command :
         {"ctl " + at + " status --token s3cret --timeout 3", "probe " + at + " --token s3cret"}) {
      const auto r = run_palp_cli(command, cache);
      EXPECT_EQ(r.exit_code, 2) << command << ": " << r.output;
      EXPECT_NE(r.output.find("--tls-ca"), std::string::npos) << command << ": " << r.output;
      EXPECT_FALSE(listener.connected()) << command << " connected";
    }
  }
  // To loopback the token may go: port 1 answers no one, so it fails connecting (exit 1).
  for (const char* host : {"127.0.0.1", "localhost"}) {
    const auto r =
        run_palp_cli(std::string("ctl ") + host + ":1 status --token s3cret --timeout 2", cache);
    EXPECT_EQ(r.exit_code, 1) << host << ": " << r.output;
    EXPECT_NE(r.output.find("cannot connect"), std::string::npos) << host << ": " << r.output;
  }
  const auto cert = run_palp_cli("ctl 127.0.0.1:1 status --tls-cert a.crt --tls-key a.key", cache);
  EXPECT_EQ(cert.exit_code, 2) << cert.output;
  EXPECT_NE(cert.output.find("--tls-ca FILE or --tls-pin"), std::string::npos) << cert.output;
}

}  // namespace
}  // namespace palp
