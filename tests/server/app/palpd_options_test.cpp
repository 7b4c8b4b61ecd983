// palpd's command line checked without a device, a scene or a port: what each option sets, the
// defaults, and the refusals (each naming its option) before anything is opened.
#include "app/palpd_options.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "base/errors.hpp"

namespace palp::app {
namespace {

const std::vector<std::string> kBase = {"--scene", "phantom:torso", "--device", "sim"};

PalpdOptions parse(std::vector<std::string> more) {
  std::vector<std::string> argv = kBase;
  argv.insert(argv.end(), more.begin(), more.end());
  auto o = parse_palpd_options(argv);
  if (!o) throw std::runtime_error("help");
  return std::move(*o);
}

std::string refusal(std::vector<std::string> argv) {
  try {
    (void)parse_palpd_options(std::move(argv));
  } catch (const UsageError& e) {
    return e.what();
  }
  return "";
}

TEST(PalpdOptions, Defaults) {
  const PalpdOptions o = parse({});
  EXPECT_EQ(o.device_spec, "sim");
  EXPECT_FALSE(o.quiet);
  EXPECT_EQ(o.tool.name, "finger:37");
  EXPECT_EQ(o.profile, nullptr);
  EXPECT_EQ(o.loop.rate_hz, 1000.0);
  EXPECT_TRUE(o.loop.realtime);
  EXPECT_EQ(o.loop.priority, 80);
  EXPECT_DOUBLE_EQ(o.loop.watchdog_late_s, 5e-3);
  EXPECT_DOUBLE_EQ(o.loop.device_timeout_s, 0.1);
  EXPECT_EQ(o.server.bind, "127.0.0.1");
  EXPECT_EQ(o.server.port, 7400);
  EXPECT_EQ(o.server.max_clients, 16u);
  EXPECT_EQ(o.server.queue_frames, 256u);
  EXPECT_EQ(o.server.max_queue_bytes, std::size_t{4} << 20);
  EXPECT_DOUBLE_EQ(o.server.poll_interval_s, 500e-6);
  EXPECT_EQ(o.duration_s, 0.0);
  EXPECT_EQ(o.record_dir, ".");
  EXPECT_EQ(o.stats_json, "");
  EXPECT_EQ(o.params.pulse_bpm, 72.0);  // a resting adult's heart rate
}

// --pulse-bpm: the arteries' heart rate, 0 (no pulse) .. 240, refused outside with its range.
TEST(PalpdOptions, ThePulseRate) {
  EXPECT_EQ(parse({"--pulse-bpm", "90"}).params.pulse_bpm, 90.0);
  EXPECT_EQ(parse({"--pulse-bpm", "0"}).params.pulse_bpm, 0.0);
  EXPECT_EQ(parse({"--pulse-bpm", "240"}).params.pulse_bpm, 240.0);
  std::vector<std::string> argv = kBase;
  argv.insert(argv.end(), {"--pulse-bpm", "241"});
  EXPECT_EQ(refusal(argv), "--pulse-bpm must be in [0, 240]");
  argv.back() = "-5";
  EXPECT_EQ(refusal(argv), "--pulse-bpm must be in [0, 240]");
  argv.back() = "fast";
  EXPECT_EQ(refusal(argv), "--pulse-bpm needs a number, got 'fast'");
  EXPECT_NE(palpd_help().find("--pulse-bpm N"), std::string::npos);
}

TEST(PalpdOptions, WhatEachSets) {
  const PalpdOptions o =
      parse({"-q", "--rate", "2000", "--port", "0", "--no-realtime", "--tool", "probe:3x3",
             "--device-profile", "touch", "--duration", "2.5", "--stats-json", "s.json",
             "--max-clients", "4", "--watchdog-ms", "0"});
  EXPECT_TRUE(o.quiet);
  EXPECT_EQ(o.loop.rate_hz, 2000.0);
  EXPECT_EQ(o.server.port, 0);
  EXPECT_FALSE(o.loop.realtime);
  EXPECT_EQ(o.tool.name, "probe:3x3");
  ASSERT_NE(o.profile, nullptr);
  EXPECT_EQ(std::string(o.profile->name), "touch");
  EXPECT_EQ(o.duration_s, 2.5);
  EXPECT_EQ(o.stats_json, "s.json");
  EXPECT_EQ(o.server.max_clients, 4u);
  EXPECT_EQ(o.loop.watchdog_late_s, 0.0);
}

TEST(PalpdOptions, HelpIsNotParsedFurther) {
  EXPECT_FALSE(parse_palpd_options({"--help"}));
  EXPECT_FALSE(parse_palpd_options({"-h", "--rate", "0"}));
  EXPECT_NE(palpd_help().find("usage: palpd --scene SCENE --device DEVICE"), std::string::npos);
  EXPECT_NE(palpd_help().find("--no-realtime"), std::string::npos);
}

TEST(PalpdOptions, Refusals) {
  EXPECT_EQ(
      refusal({"--scene", "phantom:torso"}),
      "palpd needs --device DEVICE (sim, sim:FILE, replay:FILE, remote, usb-haptic[:VID:PID])");
  EXPECT_EQ(refusal({"--device", "sim", "extra"}),
            "palpd takes no positional arguments, got 'extra'");
  auto with = [](std::vector<std::string> more) {
    std::vector<std::string> argv = kBase;
    argv.insert(argv.end(), more.begin(), more.end());
    return refusal(argv);
  };
  EXPECT_EQ(with({"--rate", "0"}), "--rate must be between 1 and 100000 Hz");
  EXPECT_EQ(with({"--port", "70000"}), "--port must be an integer in 0..65535");
  EXPECT_EQ(with({"--port", "1.5"}), "--port must be an integer in 0..65535");
  EXPECT_EQ(with({"--max-clients", "0"}), "--max-clients must be in [1, 1024]");
  EXPECT_EQ(with({"--hello-timeout", "0"}), "--hello-timeout must be in [0.1, 600]");
  EXPECT_EQ(with({"--watchdog-ms", "2000"}), "--watchdog-ms must be in [0, 1000]");
  EXPECT_EQ(with({"--duration", "-1"}), "--duration must be in [0, 1e+07]");
  EXPECT_NE(with({"--record-dir", "/proc/palpd-test"}).find("not a directory palpd can create"),
            std::string::npos);
}

TEST(PalpdOptions, RecordDirIsMadeAtParse) {
  const auto dir = std::filesystem::temp_directory_path() / "palpd_options_test_record_dir";
  std::filesystem::remove_all(dir);
  const PalpdOptions o = parse({"--record-dir", dir.string()});
  EXPECT_EQ(o.record_dir, dir.string());
  EXPECT_TRUE(std::filesystem::is_directory(dir));
  std::filesystem::remove_all(dir);
}

TEST(PalpdOptions, ConfigKeys) {
  const auto& flags = palpd_flags();
  const auto& valued = palpd_valued();
  for (const char* flag : {"help", "quiet", "no-realtime", "no-force-limits", "allow-truncated"})
    EXPECT_NE(std::find(flags.begin(), flags.end(), flag), flags.end()) << flag;
  for (const char* key : {"device", "rate", "port", "record-dir", "stats-json", "map-window"})
    EXPECT_NE(std::find(valued.begin(), valued.end(), key), valued.end()) << key;
}

TEST(PalpdOptions, OptionWithinAndPositive) {
  const cli::Args args({"--a=5", "--b=-1"}, {}, {"a", "b"});
  EXPECT_EQ(option_within(args, "a", 0, 0, 10), 5.0);
  EXPECT_EQ(option_within(args, "missing", 3, 0, 10), 3.0);
  EXPECT_THROW(option_within(args, "a", 0, 6, 10), UsageError);
  EXPECT_EQ(option_positive(args, "a", 0), 5.0);
  EXPECT_THROW(option_positive(args, "b", 0), UsageError);
}

}  // namespace
}  // namespace palp::app
