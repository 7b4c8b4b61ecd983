// palpd's Falcon options end to end (server/app/falcon_options.cpp): --device falcon without
// --falcon-firmware, with a missing or empty file (also from the config file), and the options
// given to another device are refused at start, before the scene loads or a device is awaited.
// And `palp probe` shows the device's state and message from Stats (where a Falcon's homing
// instructions appear; the device side is tested in falcon_device_test).
#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "app/falcon_options.hpp"
#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "devices/falcon_device.hpp"
#include "model/registration.hpp"
#include "support/cli_test_util.hpp"
#include "support/palpd_process.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;

testing::CliOutcome run_palpd(const std::string& args) {
  const std::string command = std::string(PALPD_PATH) + " " + args + " 2>&1 </dev/null";
  testing::CliOutcome outcome;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return outcome;
  std::array<char, 4096> buffer{};
  while (fgets(buffer.data(), buffer.size(), pipe)) outcome.output += buffer.data();
  const int status = pclose(pipe);
  outcome.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return outcome;
}

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(FalconOptions, FirmwareIsRequiredAndCheckedBeforeTheSceneLoads) {
  // The scene does not exist: had palpd looked at it first, the error would name it.
  const std::string scene = "--scene /nonexistent/ct.nii.gz --no-realtime";
  auto r = run_palpd(scene + " --device falcon");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "--falcon-firmware FILE")) << r.output;
  EXPECT_TRUE(has(r.output, "does not ship")) << r.output;

  r = run_palpd(scene + " --device falcon --falcon-firmware /nonexistent/novint.bin");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_TRUE(has(r.output, "/nonexistent/novint.bin: cannot open")) << r.output;
  EXPECT_FALSE(has(r.output, "ct.nii.gz")) << r.output;

  const fs::path dir = fs::temp_directory_path() / ("palp-falcon-opt-" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string empty = (dir / "empty.bin").string();
  std::ofstream(empty).close();
  r = run_palpd(scene + " --device falcon:1 --falcon-firmware " + empty);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_TRUE(has(r.output, "the file is empty")) << r.output;

  // the config file's key, as every palpd option
  const std::string config = (dir / "palpd.toml").string();
  std::ofstream(config) << "device = \"falcon\"\nfalcon-firmware = \"/nonexistent/fw.bin\"\n";
  r = run_palpd(scene + " --config " + config);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_TRUE(has(r.output, "/nonexistent/fw.bin: cannot open")) << r.output;
  fs::remove_all(dir);

  r = run_palpd(scene + " --device falcon:x --falcon-firmware " + config);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "falcon:INDEX")) << r.output;
}

TEST(FalconOptions, OtherDevicesRefuseTheFalconOptions) {
  auto r = run_palpd("--scene phantom:sphere --no-realtime --device sim --falcon-firmware x.bin");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "apply to --device falcon only")) << r.output;
  r = run_palpd("--help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_TRUE(has(r.output, "--falcon-firmware FILE")) << r.output;
  EXPECT_TRUE(has(r.output, "falcon[:INDEX]")) << r.output;
}

// The fixed 3-DOF tool, placed on the patient, points into the skin from the side asked for:
// tool +z (the outward normal the pad presses against) along that patient direction in the scene.
TEST(FalconOptions, ToolOrientationPointsIntoTheSkinFromTheSideAsked) {
  Scene scene;  // the default grid: LPS, so the patient frame is the scene frame
  const PatientFrame frame = patient_frame(scene.grid);
  net::SceneDescription::Placement placement;
  placement.registration.rotation = rotation_from_axes(frame, "IAR");
  for (const char* side : {"anterior", "left", "superior"}) {
    SCOPED_TRACE(side);
    rt::FalconDevice device(rt::FalconDevice::Options{});
    const cli::Args args({"--falcon-tool-from", side}, {}, {"falcon-tool-from"});
    app::orient_falcon(args, device, scene, placement);
    Pose in_device;
    in_device.orientation = device.tool_orientation();
    const Quat q = to_scene(placement.registration, in_device).orientation;
    Anatomy direction{};
    ASSERT_TRUE(parse_anatomy(side, &direction));
    const Vec3d z = rotate(q, {0, 0, 1}), expected = frame.toward(direction);
    EXPECT_NEAR(z.x, expected.x, 1e-9);
    EXPECT_NEAR(z.y, expected.y, 1e-9);
    EXPECT_NEAR(z.z, expected.z, 1e-9);
  }
  rt::FalconDevice device(rt::FalconDevice::Options{});
  EXPECT_THROW(app::orient_falcon(cli::Args({"--falcon-tool-from", "up"}, {}, {"falcon-tool-from"}),
                                  device, scene, placement),
               UsageError);
}

TEST(FalconOptions, ProbeShowsTheDeviceStateFromStats) {
  const fs::path dir =
      fs::temp_directory_path() / ("palp-falcon-probe-" + std::to_string(getpid()));
  fs::create_directories(dir);
  const fs::path log = dir / "palpd.log";
  const int port = testing::start_palpd(
      "--scene phantom:sphere --device sim --port 0 --duration 4 --no-realtime", log);
  ASSERT_GT(port, 0) << testing::read_text(log);
  // Stats come every second: 2.5 s of probing sees at least one
  const auto probe = testing::run_palp_cli(
      "probe 127.0.0.1:" + std::to_string(port) + " --duration 2.5", dir / "cache");
  EXPECT_EQ(probe.exit_code, 0) << probe.output;
  EXPECT_TRUE(has(probe.output, "  status    device present")) << probe.output;
  EXPECT_FALSE(has(probe.output, "exchanges")) << probe.output;  // sim has no framed link
  EXPECT_TRUE(testing::wait_palpd_exit(log));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace palp
