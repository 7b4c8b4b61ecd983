// palpd --dds end to end on loopback: palp probe --dds gets every topic, the rig list shows the
// rig, device poses over DDS count only with palpd's token, and the options' errors. Each test
// its own DDS domain and a Cyclone configuration restricted to loopback (support/dds_loopback).
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "base/vec.hpp"
#include "dds_subscriber.hpp"
#include "support/cli_test_util.hpp"
#include "support/dds_loopback.hpp"
#include "support/palpd_process.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using testing::run_command;
using testing::start_palpd;
using testing::unique_dds_domain;

fs::path temp_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("palp_dds_" + name + std::to_string(getpid()));
  fs::create_directories(dir);
  return dir;
}

nlohmann::json last_json(const std::string& text) {
  return nlohmann::json::parse(testing::last_line(text));
}

class PalpdDds : public ::testing::Test {
 protected:
  void SetUp() override { testing::use_dds_loopback(); }
};

TEST_F(PalpdDds, ProbeGetsEveryTopicAndListsTheRig) {
  const fs::path dir = temp_dir("probe");
  const std::string domain = std::to_string(unique_dds_domain());
  const int port = start_palpd("--scene phantom:cube --device sim --port 0 --duration 8 --dds " +
                                   domain + " --rig e2e --dds-volume-max-dim 16",
                               dir / "palpd.log");
  ASSERT_GT(port, 0) << testing::read_text(dir / "palpd.log");
  EXPECT_NE(testing::read_text(dir / "palpd.log").find("DDS domain " + domain + ", rig e2e"),
            std::string::npos);
  const auto probe = run_command(std::string(PALP_CLI_PATH) + " probe --dds " + domain +
                                 " --rig e2e --duration 2 --ros --volume -q");
  ASSERT_EQ(probe.exit_code, 0) << probe.output;
  const nlohmann::json j = last_json(probe.output);
  EXPECT_TRUE(j["ok"].get<bool>());
  EXPECT_GT(j["frames"].get<int>(), 200);  // 2 s at 1 kHz, on a busy machine
  EXPECT_GT(j["delivered"].get<double>(), 0.5);
  EXPECT_LE(j["delivered"].get<double>(), 1.0);
  EXPECT_TRUE(j["scene"].get<bool>());  // transient-local: there before the probe came
  EXPECT_TRUE(j["stats"].get<bool>());
  EXPECT_GT(j["tool_pose"].get<int>(), 0);
  EXPECT_GT(j["wrench"].get<int>(), 0);
  EXPECT_GT(j["volume_chunks"].get<int>(), 0);
  EXPECT_NEAR(j["server_rate_hz"].get<double>(), 1000.0, 100.0);
  EXPECT_GE(j["subscribers"].get<int>(), 1);

  const auto list = run_command(std::string(PALP_CLI_PATH) + " probe --dds " + domain +
                                " --list --duration 1 -q");
  ASSERT_EQ(list.exit_code, 0) << list.output;
  const nlohmann::json rigs = last_json(list.output)["rigs"];
  ASSERT_EQ(rigs.size(), 1u) << list.output;
  EXPECT_EQ(rigs[0]["rig"], "e2e");
  EXPECT_TRUE(rigs[0]["alive"].get<bool>());
  EXPECT_EQ(rigs[0]["rate_hz"].get<double>(), 1000.0);

  // Frames with their contacts: finger:37 has 37 points.
  const auto full = run_command(std::string(PALP_CLI_PATH) + " probe --dds " + domain +
                                " --rig e2e --duration 1 --contacts -q");
  ASSERT_EQ(full.exit_code, 0) << full.output;
  EXPECT_GT(last_json(full.output)["frames"].get<int>(), 100);

  // Another rig's name gets nothing.
  const auto other = run_command(std::string(PALP_CLI_PATH) + " probe --dds " + domain +
                                 " --rig other --duration 1 --stall 1 -q");
  EXPECT_EQ(other.exit_code, 1) << other.output;
  EXPECT_EQ(last_json(other.output)["frames"].get<int>(), 0);
  EXPECT_TRUE(testing::stop_palpd(dir / "palpd.log"));
  EXPECT_NE(testing::read_text(dir / "palpd.log").find("DDS rig e2e: "), std::string::npos);
  fs::remove_all(dir);
}

// frame_batch (--dds-batch-ms): a batch subscriber gets every frame index, in order, each
// batch at most the frames of 10 ms of loop time, nearly all of them full (the first may be
// partial: the subscriber joined in it; a late tick may shift a boundary).
TEST_F(PalpdDds, BatchSubscriberGetsEveryFrameContiguous) {
  const fs::path dir = temp_dir("batch");
  const std::string domain = std::to_string(unique_dds_domain());
  const int port = start_palpd("--scene phantom:cube --device sim --port 0 --duration 8 --dds " +
                                   domain + " --rig batch --dds-batch-ms 10 --dds-volume-max-dim 0",
                               dir / "palpd.log");
  ASSERT_GT(port, 0) << testing::read_text(dir / "palpd.log");
  EXPECT_NE(testing::read_text(dir / "palpd.log").find("frames_contacts,frame_batch,"),
            std::string::npos);
  dds::SubscriberOptions o;
  o.domain = static_cast<std::uint32_t>(std::stoi(domain));
  o.rig = "batch";
  o.batch = true;
  o.scene = o.stats = false;
  dds::RigSubscriber sub(o);
  std::uint64_t frames = 0, first = 0, last = 0, breaks = 0, seq = 0;
  dds::Handlers h;
  h.frame = [&](const palp_dds_HapticFrame& f, std::int64_t) {
    EXPECT_STREQ(f.rig, "batch");
    if (frames == 0)
      first = f.frame_index;
    else if (f.frame_index != last + 1 || f.seq <= seq)
      ++breaks;
    last = f.frame_index, seq = f.seq;
    ++frames;
  };
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (std::chrono::steady_clock::now() < end) {
    if (!sub.wait(0.05)) continue;
    sub.take(h);
  }
  sub.take(h);
  EXPECT_EQ(breaks, 0u) << "frames " << first << ".." << last << ", " << frames << " taken";
  EXPECT_EQ(frames, last - first + 1);
  EXPECT_GT(frames, 1000u);  // about 3 s at 1 kHz, after discovery
  const std::uint64_t batches = sub.batches();
  EXPECT_GE(frames, 9 * batches) << batches << " batches";
  EXPECT_LE(frames, 10 * batches) << batches << " batches";
  EXPECT_TRUE(testing::stop_palpd(dir / "palpd.log"));
  EXPECT_NE(testing::read_text(dir / "palpd.log").find(" batches, "), std::string::npos)
      << testing::read_text(dir / "palpd.log");
  fs::remove_all(dir);
}

// Writes DevicePoses at `where` with `token` for `seconds` while taking frames; true when a
// frame showed the device there.
bool drive(const std::string& domain, const std::string& token, Vec3d where, double seconds) {
  dds::SubscriberOptions o;
  o.domain = static_cast<std::uint32_t>(std::stoi(domain));
  o.rig = "ctl";
  o.scene = o.stats = false;
  dds::RigSubscriber sub(o);
  const dds::Entity participant = dds::make_participant(o.domain);
  const dds_entity_t topic = dds::make_topic(participant.get(), &palp_dds_DevicePose_desc,
                                             dds::topic_name("ctl", dds::kDevicePose));
  const dds::QosPtr qos = dds::make_qos(dds::QosKind::Command, 1);
  const dds_entity_t w = dds_create_writer(participant.get(), topic, qos.get(), nullptr);
  EXPECT_GT(w, 0);
  std::vector<char> text(token.begin(), token.end());
  text.push_back('\0');
  bool seen = false;
  dds::Handlers h;
  h.frame = [&](const palp_dds_HapticFrame& f, std::int64_t) {
    if (std::abs(f.position.x - where.x) < 1e-9 && std::abs(f.position.y - where.y) < 1e-9 &&
        std::abs(f.position.z - where.z) < 1e-9)
      seen = true;
  };
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  std::uint64_t seq = 0;
  while (std::chrono::steady_clock::now() < end && !seen) {
    palp_dds_DevicePose p{};
    std::snprintf(p.rig, sizeof p.rig, "ctl");
    std::snprintf(p.token, sizeof p.token, "%s", text.data());
    p.seq = seq++;
    p.position = {where.x, where.y, where.z};
    p.orientation = {1, 0, 0, 0};
    dds_write(w, &p);
    if (sub.wait(0.01)) sub.take(h);
  }
  return seen;
}

TEST_F(PalpdDds, DevicePosesNeedTheToken) {
  const fs::path dir = temp_dir("ctl");
  const std::string domain = std::to_string(unique_dds_domain());
  const int port = start_palpd(
      "--scene phantom:cube --device remote --port 0 --duration 12 "
      "--token s3cret --dds " +
          domain + " --rig ctl --dds-control --dds-volume-max-dim 0",
      dir / "palpd.log");
  ASSERT_GT(port, 0) << testing::read_text(dir / "palpd.log");
  EXPECT_FALSE(drive(domain, "wrong", {1.25, 2.5, 3.75}, 2.0));
  EXPECT_TRUE(drive(domain, "s3cret", {4.5, 5.25, 6.0}, 5.0));
  EXPECT_NE(
      testing::read_text(dir / "palpd.log").find("DDS device pose refused (wrong rig or token)"),
      std::string::npos);
  EXPECT_TRUE(testing::stop_palpd(dir / "palpd.log"));
  fs::remove_all(dir);
}

TEST_F(PalpdDds, OptionErrorsSayWhatIsWrong) {
  const std::string palpd = PALPD_PATH;
  const auto no_token =
      run_command(palpd + " --scene phantom:cube --device remote --dds 3 --dds-control 2>&1");
  EXPECT_EQ(no_token.exit_code, 2) << no_token.output;
  EXPECT_NE(no_token.output.find("--dds-control needs --token"), std::string::npos);
  const auto no_dds = run_command(palpd + " --scene phantom:cube --device sim --rig x 2>&1");
  EXPECT_EQ(no_dds.exit_code, 2);
  EXPECT_NE(no_dds.output.find("--rig needs --dds"), std::string::npos) << no_dds.output;
  const auto domain = run_command(palpd + " --scene phantom:cube --device sim --dds 300 2>&1");
  EXPECT_EQ(domain.exit_code, 2);
  EXPECT_NE(domain.output.find("0..232"), std::string::npos) << domain.output;
  const auto batch =
      run_command(palpd + " --scene phantom:cube --device sim --dds --dds-batch-ms 101 2>&1");
  EXPECT_EQ(batch.exit_code, 2);
  EXPECT_NE(batch.output.find("--dds-batch-ms must be 0 (off) or in 1..100 ms"), std::string::npos)
      << batch.output;
  const auto both =
      run_command(std::string(PALP_CLI_PATH) + " probe --dds 3 --batch --contacts 2>&1");
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.output.find("use one of --batch, --contacts"), std::string::npos) << both.output;
  const auto rig = run_command(palpd + " --scene phantom:cube --device sim --dds --rig a-b 2>&1");
  EXPECT_EQ(rig.exit_code, 2);
  EXPECT_NE(rig.output.find("rig name 'a-b'"), std::string::npos) << rig.output;
}

}  // namespace
}  // namespace palp
