// Training tasks end to end (issue 40): palpd with a landmarks file and a scripted device that
// presses on the sphere phantom's right side, the instructor's console starting a ptcd task,
// marking and stopping it; the score in TaskStatus, the session report and the cohort CSV; an
// observer that may not start or mark; oversized landmarks refused at start; the marks kept beside
// a recording.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "anatomy/landmarks.hpp"
#include "rt/recording.hpp"
#include "support/cli_test_util.hpp"
#include "support/net_test_client.hpp"
#include "support/palpd_process.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using testing::read_text;
using testing::run_palp_cli;
using testing::shared_cli_dir;

// The sphere phantom: radius 30 mm about the grid's centre, which its placement puts at LPS
// (0, 0, 0) (identity direction, origin at minus half the extent). Its right side (LPS -x) is the
// "chest wall" here: rib 9 and rib 10 run along it 12 mm above and below the equator, and the
// 9th/10th intercostal space's skin point is the equator's rightmost point.
constexpr double kRadius = 30.0, kRibLevel = 12.0;
const Vec3d kTarget{-kRadius, 0.0, 0.0};

anatomy::Rib rib(int number, double z) {
  anatomy::Rib r;
  r.number = number;
  r.confidence = 1.0;
  for (double y = -15.0; y <= 15.0; y += 5.0)
    r.points.push_back({-std::sqrt(kRadius * kRadius - z * z - y * y), y, z});
  return r;
}

fs::path write_fixture_landmarks(const fs::path& dir, int extra_ribs = 0) {
  anatomy::Landmarks l;
  l.scene = "phantom:sphere";
  anatomy::IntercostalSpace space;
  space.upper_rib = 9;
  space.skin_point = kTarget;
  space.normal = Vec3d{-1.0, 0.0, 0.0};
  space.confidence = 1.0;
  l.intercostal_spaces.push_back(space);
  l.ribs.push_back(rib(9, kRibLevel));
  l.ribs.push_back(rib(10, -kRibLevel));
  for (int i = 0; i < extra_ribs; ++i) l.ribs.push_back(rib(11, -20.0));
  const fs::path path = dir / (extra_ribs ? "huge.json" : "landmarks.json");
  anatomy::write_landmarks(path.string(), l);
  return path;
}

// The device comes in from the patient's right along +x (scene frame = LPS + 49.5 mm), the pad
// facing the sphere, to 3 mm deep over the space and holds there.
fs::path write_press(const fs::path& dir) {
  const fs::path path = dir / "press.csv";
  std::ofstream out(path);
  out << "t,px,py,pz,qw,qx,qy,qz\n";
  const double c = 49.5, q = std::sqrt(0.5);
  for (int i = 0; i <= 10; ++i) {
    const double x = c - kRadius - 15.0 + 1.8 * i;  // to 3 mm inside the skin
    out << 0.1 * i << ',' << x << ',' << c << ',' << c << ',' << q << ",0," << -q << ",0\n";
  }
  out << "600," << c - kRadius + 3.0 << ',' << c << ',' << c << ',' << q << ",0," << -q << ",0\n";
  return path;
}

double number_after(const std::string& text, const std::string& before) {
  const auto at = text.find(before);
  return at == std::string::npos ? -1.0 : std::stod(text.substr(at + before.size()));
}

TEST(PalpdTask, AScriptedTraineeMarksTheSpaceAndIsScored) {
  const fs::path dir = shared_cli_dir() / "task-e2e";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path log = dir / "palpd.log", reports = dir / "reports";
  const int port =
      testing::start_palpd("--scene phantom:sphere --device sim:" + write_press(dir).string() +
                               " --port 0 --duration 20 --no-realtime --landmarks " +
                               write_fixture_landmarks(dir).string() + " --task-report-dir " +
                               reports.string() + " --record-dir " + (dir / "rec").string(),
                           log);
  ASSERT_GT(port, 0) << read_text(log);
  const std::string at = "ctl 127.0.0.1:" + std::to_string(port) + " ";
  const fs::path cache = dir / "cache";

  // an observer may neither start nor mark: the server refuses the Command itself
  testing::TestClient observer(static_cast<std::uint16_t>(port));
  observer.hello();
  v1::ServerMessage m;
  ASSERT_TRUE(observer.wait_for_case(v1::ServerMessage::kLandmarks, m)) << read_text(log);
  EXPECT_EQ(m.landmarks().landmarks_size(), 1 + 2 * 7);  // the space, two ribs of 7 points
  for (const bool start : {true, false}) {
    v1::ClientMessage c;
    if (start)
      c.mutable_command()->mutable_task_start()->set_kind("ptcd");
    else
      c.mutable_command()->mutable_task_mark();
    observer.send(c);
    ASSERT_TRUE(observer.wait_for_case(v1::ServerMessage::kError, m));
    EXPECT_EQ(m.error().code(), v1::Error::PERMISSION_DENIED);
  }

  auto r = run_palp_cli(at + "task mark", cache);
  EXPECT_EQ(r.exit_code, 1) << r.output;  // no task yet
  EXPECT_NE(r.output.find("task mark: refused: no task is running"), std::string::npos) << r.output;
  r = run_palp_cli(at + "record start trial", cache);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  r = run_palp_cli(at + "task start ptcd --space 9 --side right", cache);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("task start ptcd --side right --space 9: ok"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("ptcd right 9/10, running, trial 1"), std::string::npos) << r.output;
  // the controller (the trainee) is told no score and may not show the landmarks
  EXPECT_NE(r.output.find("hidden from this client"), std::string::npos) << r.output;
  r = run_palp_cli(at + "task start lumbar", cache);
  EXPECT_EQ(r.exit_code, 1) << r.output;  // one task at a time

  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // pressing on the space
  r = run_palp_cli(at + "task mark", cache);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output.find("last mark"), std::string::npos) << r.output;  // not for the trainee
  r = run_palp_cli(at + "task status", cache);                           // the instructor's view
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("1 mark"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("in the target (target)"), std::string::npos) << r.output;
  // the mark is the mean of the pad's proxies on the skin, over the space: off it by at most the
  // sphere's sagitta under the pad (finger:37, 7.5 mm across its rim: 0.9 mm), a voxel of the
  // map's surface (1 mm) and the proxies' friction lag (measured: 1.7 mm)
  const double distance = number_after(r.output, "last mark  ");
  EXPECT_GE(distance, 0.0) << r.output;
  EXPECT_LT(distance, 3.0) << r.output;

  r = run_palp_cli(at + "task stop", cache);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::smatch report;
  const std::string out = r.output;
  ASSERT_TRUE(std::regex_search(out, report, std::regex("report +(\\S+)"))) << out;
  EXPECT_NE(read_text(report[1].str()).find("ptcd right 9/10"), std::string::npos);
  const std::string cohort = read_text(reports / "cohort.csv");
  EXPECT_NE(cohort.find(",1,1,target,1,"), std::string::npos) << cohort;  // trial 1, in target
  r = run_palp_cli(at + "record stop", cache);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  const auto marks = rt::read_recording_marks((dir / "rec" / "trial.marks.csv").string());
  ASSERT_EQ(marks.size(), 1u);
  EXPECT_GT(marks[0].t, 1.0);
  const rt::Recording rec = rt::read_recording((dir / "rec" / "trial").string());
  EXPECT_LT(marks[0].tick, rec.records.size());
  observer.close();
  EXPECT_TRUE(testing::stop_palpd(log)) << read_text(log);
}

TEST(PalpdTask, OptionsAreCheckedAtStart) {
  const fs::path dir = shared_cli_dir() / "task-options";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string base = "--scene phantom:sphere --device sim --no-realtime --duration 1 ";
  const auto palpd = [&](const std::string& args) {
    return testing::run_command("PALP_SCENE_CACHE='" + (shared_cli_dir() / "cache").string() +
                                "' " + PALPD_PATH + " " + base + args + " 2>&1 </dev/null");
  };
  // no --landmarks: found in the scene, and a sphere has no ribs
  auto r = palpd("--task ptcd");
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("the landmarks have no right intercostal space 9/10"), std::string::npos)
      << r.output;
  r = palpd("--task appendix --landmarks " + write_fixture_landmarks(dir).string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = palpd("--task-side left");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  // more points than the clients are sent (1024): refused before anything starts
  r = palpd("--landmarks " + write_fixture_landmarks(dir, 200).string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("more than 1024"), std::string::npos) << r.output;
  // a target the landmarks do not show
  r = palpd("--task ptcd --task-space 5 --landmarks " + write_fixture_landmarks(dir).string());
  EXPECT_NE(r.exit_code, 0) << r.output;
}

}  // namespace
}  // namespace palp
