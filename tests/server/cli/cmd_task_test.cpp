// palp task as a user meets it: a scripted trainee slides superior over the cube phantom (stored
// ILA, so the scene frame is not the patient's) across landmarks placed on it, marks rib 10 in
// trial 1 and the 9/10 space in trial 2; the summary, the report and the cohort CSV say so, two
// runs write the same report byte for byte, and mistakes give one-line errors with the
// documented exit codes.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "anatomy/landmarks.hpp"
#include "base/patient_frame.hpp"
#include "scene/scene.hpp"
#include "scene/trajectory.hpp"
#include "support/cli_test_util.hpp"
#include "training/cohort_csv.hpp"

namespace {

namespace fs = std::filesystem;
using palp::Vec3d;
using palp::testing::read_text;
using palp::testing::run_palp_cli;
using palp::testing::shared_cli_dir;

// The device point at t: the fingertip (finger:1's contact point, 8 mm below the device point)
// pressing 2 mm into the cube's anterior face (scene z = 119.5) by t = 0.1 s, then sliding towards
// the patient's superior (scene -x, the cube is stored ILA) 20 mm in 0.9 s.
Vec3d device_at(double t) {
  if (t <= 0.1) return {70.0, 70.0, 132.0 - 65.0 * t};
  return {70.0 - 20.0 * (t - 0.1) / 0.9, 70.0, 125.5};
}

struct Files {
  std::string trajectory, landmarks, marks, marks_one_trial;
};

// Landmarks on the cube in LPS: the 9/10 space's skin point where the device is at t = 0.95,
// ribs 8, 9 and 10 every 25 mm across the face 14.5 mm under the skin.
const Files& files() {
  static const Files f = [] {
    Files out;
    const fs::path dir = shared_cli_dir();
    palp::Trajectory trajectory;
    for (int i = 0; i <= 1000; ++i) trajectory.push_back({i * 0.001, {device_at(i * 0.001), {}}});
    out.trajectory = (dir / "task_slide.csv").string();
    palp::write_trajectory_csv(out.trajectory, trajectory);

    // The scene's own grid, as palp task loads it (its placement maps scene to LPS).
    palp::SceneOptions options;
    options.cache_dir = (dir / "cache").string();
    const palp::Grid grid = palp::load_scene("phantom:cube", options).grid;
    const double i_target = device_at(0.95).x;
    palp::anatomy::Landmarks lm;
    lm.scene = "phantom:cube";
    for (const int n : {8, 9, 10}) {
      palp::anatomy::Rib rib;
      rib.number = n;
      rib.confidence = 1.0;
      for (double j = 20.0; j <= 120.0; j += 10.0)
        rib.points.push_back(palp::world_of_scene(grid, {i_target + 25.0 * (n - 9.5), j, 105.0}));
      lm.ribs.push_back(rib);
    }
    palp::anatomy::IntercostalSpace space;
    space.upper_rib = 9;
    space.skin_point = palp::world_of_scene(grid, {i_target, 70.0, 119.5});
    space.normal = Vec3d{0.0, -1.0, 0.0};  // anterior
    lm.intercostal_spaces.push_back(space);
    out.landmarks = (dir / "task_landmarks.json").string();
    palp::anatomy::write_landmarks(out.landmarks, lm);

    out.marks = (dir / "task_marks.csv").string();
    std::ofstream(out.marks) << "trial,t\n1,0.5\n2,0.95\n";
    out.marks_one_trial = (dir / "task_marks_one.csv").string();
    std::ofstream(out.marks_one_trial) << "t\r\n0.5\r\n0.95\r\n";
    return out;
  }();
  return f;
}

std::string task_args(const std::string& marks, const fs::path& out) {
  const Files& f = files();
  return "task ptcd --scene phantom:cube --tool finger:1 --landmarks " + f.landmarks +
         " --trajectory " + f.trajectory + " --marks " + marks + " --out " + out.string() +
         " --trainee t-01";
}

TEST(CmdTask, ScoresTheTrialsAndWritesTheReportAndTheCohortRows) {
  const fs::path out = shared_cli_dir() / "session-a";
  const fs::path csv = shared_cli_dir() / "cohort.csv";
  fs::remove(csv);
  const auto run = run_palp_cli(task_args(files().marks, out) + " --csv " + csv.string(),
                                shared_cli_dir() / "cache");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("task ptcd right 9/10, session session-a: 2 trials"), std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find("rib 10"), std::string::npos) << run.output;
  const std::string page = read_text(out / "report.html");
  EXPECT_NE(page.find("<td class=\"text\">rib 10</td><td class=\"miss\">no</td>"),
            std::string::npos);
  EXPECT_NE(page.find("<td class=\"text\">target</td><td class=\"hit\">yes</td>"),
            std::string::npos);
  EXPECT_NE(page.find("trainee <b id=\"trainee\">t-01</b>"), std::string::npos);

  std::ifstream in(csv);
  std::string header, one, two;
  std::getline(in, header), std::getline(in, one), std::getline(in, two);
  EXPECT_EQ(header, palp::training::kCohortCsvHeader);
  EXPECT_EQ(one.rfind("session-a,t-01,ptcd right 9/10,phantom:cube,1,1,rib 10,0,", 0), 0u) << one;
  EXPECT_EQ(two.rfind("session-a,t-01,ptcd right 9/10,phantom:cube,2,1,target,1,", 0), 0u) << two;
  // Trial 2's answer: the proxy trails the fingertip by its friction spring, a fraction of a mm.
  const double distance = std::stod(two.substr(two.find(",target,1,") + 10));
  EXPECT_LT(distance, 1.0) << two << "\n"
                           << page.substr(page.find("target at"), 120) << "\n"
                           << page.substr(page.rfind("point (LPS mm)"), 300);
  // Trial 2 starts the row after trial 1's mark and runs to the end: 0.499 s.
  EXPECT_EQ(two.substr(two.rfind(',') + 1), "0.499") << two;
}

TEST(CmdTask, TwoRunsWriteTheSameReport) {
  const fs::path a = shared_cli_dir() / "same-a", b = shared_cli_dir() / "same-b";
  for (const fs::path& out : {a, b}) {
    const auto run = run_palp_cli(task_args(files().marks_one_trial, out) + " --session s -q",
                                  shared_cli_dir() / "cache");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    EXPECT_EQ(run.output, "") << "--quiet";
  }
  const std::string page = read_text(a / "report.html");
  EXPECT_EQ(page, read_text(b / "report.html"));
  EXPECT_NE(page.find("<tr data-trial=\"1\"><td>1</td><td>2</td><td class=\"text\">target</td>"),
            std::string::npos)
      << "one trial, two marks, the last in the space";
}

TEST(CmdTask, MistakesAreOneLineErrors) {
  const fs::path out = shared_cli_dir() / "bad";
  const fs::path cache = shared_cli_dir() / "cache";
  const fs::path late = shared_cli_dir() / "late_marks.csv";
  std::ofstream(late) << "t\n2.5\n";
  struct Case {
    std::string args;
    int code;
    std::string says;
  } cases[] = {
      {"task knee --scene phantom:cube", 2, "unknown task 'knee'"},
      {"task ptcd --space 12 --scene phantom:cube", 2, "1..11"},
      {"task lumbar --interspace L2/L4 --scene phantom:cube", 2, "L1/L2"},
      // no --landmarks: found in the scene, where a cube has no ribs
      {"task ptcd --scene phantom:cube -q --trajectory " + files().trajectory, 1,
       "no right intercostal space 9/10"},
      {task_args(late.string(), out), 1, "outside the run"},
      {task_args(files().marks, out) + " --space 8", 1, "no right intercostal space 8/9"},
  };
  for (const Case& c : cases) {
    const auto run = run_palp_cli(c.args, cache);
    EXPECT_EQ(run.exit_code, c.code) << c.args << "\n" << run.output;
    EXPECT_NE(run.output.find(c.says), std::string::npos) << c.args << "\n" << run.output;
  }
}

}  // namespace
