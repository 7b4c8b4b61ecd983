// palp traj: every KIND writes a readable trajectory CSV; options that do not apply and other
// usage mistakes are one-line errors with exit code 2.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "anatomy/trunk_truth.hpp"
#include "scene/trajectory.hpp"
#include "support/cli_test_util.hpp"
#include "training/task.hpp"

namespace {

namespace fs = std::filesystem;
using palp::testing::count_lines;
using palp::testing::last_line;
using palp::testing::read_text;
using palp::testing::run_palp_cli;
using palp::testing::shared_cli_dir;

fs::path cache() {
  return shared_cli_dir() / "cache";
}

TEST(CmdTraj, EveryKindWritesATrajectory) {
  struct Case {
    const char* args;
    std::size_t rows;
  };
  for (const Case& c : {Case{"slide-ramp --scene phantom:cube", 6001},
                        Case{"slide-speed --scene phantom:cube --speeds 10,20 --rate 500", 1501},
                        Case{"press-hold --scene phantom:cube --jitter 0.05 --shift 1", 4501},
                        Case{"ribs --scene phantom:torso --tool probe:9x3 --depth 3", 5751}}) {
    const fs::path out = shared_cli_dir() / "t.csv";
    const auto r = run_palp_cli("traj " + std::string(c.args) + " --out " + out.string(), cache());
    ASSERT_EQ(r.exit_code, 0) << c.args << ": " << r.output;
    EXPECT_NE(r.output.find("wrote"), std::string::npos) << r.output;
    const palp::Trajectory t = palp::read_trajectory_csv(out.string());
    EXPECT_EQ(t.size(), c.rows) << c.args;
    // Deterministic: the same command writes the same bytes.
    const std::string first = read_text(out);
    ASSERT_EQ(
        run_palp_cli("traj " + std::string(c.args) + " --out " + out.string(), cache()).exit_code,
        0);
    EXPECT_EQ(read_text(out), first) << c.args;
  }
}

TEST(CmdTraj, HelpAndUsageMistakes) {
  const auto help = run_palp_cli("traj --help", cache());
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("usage: palp traj"), std::string::npos);
  const std::string out = " --out " + (shared_cli_dir() / "u.csv").string();
  for (const std::string& args : {std::string("traj"), "traj wiggle --scene phantom:cube" + out,
                                  "traj ribs" + out, std::string("traj ribs --scene phantom:cube"),
                                  "traj ribs --scene phantom:torso --speeds 1,2" + out,
                                  "traj slide-ramp --scene phantom:cube --azimuth 3" + out,
                                  "traj slide-ramp --scene phantom:cube --rate 0" + out,
                                  "traj slide-ramp --scene phantom:cube --duration -1" + out,
                                  "traj slide-speed --scene phantom:cube --speeds 10,,3" + out,
                                  "traj press-hold --scene phantom:cube --seed 1.5" + out,
                                  "traj press-hold --scene phantom:cube --side up" + out,
                                  "traj ribs --scene phantom:torso --body-side middle" + out,
                                  "traj ribs --scene phantom:torso --from 2" + out,
                                  "traj ribs --scene phantom:torso --tool hand" + out}) {
    const auto r = run_palp_cli(args, cache());
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.output;
    EXPECT_EQ(count_lines(r.output), 1) << args << ": " << r.output;
  }
}

TEST(CmdTraj, SceneWithoutSkinOnThatSideExitsOne) {
  const auto r = run_palp_cli("traj press-hold --scene phantom:torso --side +z --out " +
                                  (shared_cli_dir() / "v.csv").string(),
                              cache());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("+z"), std::string::npos) << r.output;
}

// --- traj search: the scripted trainee, scored by palp task on the trunk phantom's truth -----

// The trunk phantom's exact landmarks, written once as palp landmarks would.
const std::string& trunk_landmarks() {
  static const std::string path = [] {
    const std::string p = (shared_cli_dir() / "trunk_truth.json").string();
    palp::anatomy::write_landmarks(p, palp::anatomy::trunk_landmark_truth());
    return p;
  }();
  return path;
}

struct ScoredRow {
  std::string where;
  bool in_target = false;
  double distance_mm = 0.0;
};

// Splits one cohort CSV row (no quoted cells in these) into where, in_target, distance_mm.
ScoredRow scored_row(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream in(line);
  for (std::string cell; std::getline(in, cell, ',');) cells.push_back(cell);
  EXPECT_GE(cells.size(), 9u) << line;
  if (cells.size() < 9) return {};
  return {cells[6], cells[7] == "1", std::stod(cells[8])};
}

// The trunk phantom with its maps on its own 2.5-3 mm grid: refining them to 1.5 mm in memory
// (palp's default --map-spacing 2) took 7 s of every command here.
const std::string kTrunkScene = " --scene phantom:trunk --map-spacing 0";

// traj search SEARCH_ARGS with misses 0 and 20, then palp task TASK_ARGS on it: the trials' rows.
std::vector<ScoredRow> search_and_score(const std::string& name, const std::string& search_args,
                                        const std::string& task_args) {
  const fs::path dir = shared_cli_dir() / name;
  fs::create_directories(dir);
  const std::string traj = (dir / "run.csv").string(), marks = (dir / "marks.csv").string();
  const std::string csv = (dir / "cohort.csv").string();
  const std::string common = kTrunkScene + " --landmarks " + trunk_landmarks();
  const auto r = run_palp_cli("traj search" + common + " " + search_args + " --miss 0,20 --out " +
                                  traj + " --marks " + marks,
                              cache());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  const auto t = run_palp_cli("task " + task_args + common + " --trajectory " + traj + " --marks " +
                                  marks + " --csv " + csv,
                              cache());
  EXPECT_EQ(t.exit_code, 0) << r.output << t.output;
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // the header
  std::vector<ScoredRow> rows;
  while (std::getline(in, line)) rows.push_back(scored_row(line));
  return rows;
}

// Where a mark `up_mm` superior of the right 9/10 space's point lies, from the truth's ribs 9
// and 10 at the mid-axillary line (docs/tasks.md: within 6 mm of a rib's line is on it).
std::string ptcd_expected(double up_mm) {
  const palp::TrunkTruth truth = palp::trunk_truth();
  double z9 = 0.0, z10 = 0.0, target = 0.0;
  for (const palp::TrunkRib& rib : truth.ribs) {
    if (rib.side != palp::TrunkSide::right || !rib.mid_axillary) continue;
    if (rib.number == 9) z9 = rib.mid_axillary->z;
    if (rib.number == 10) z10 = rib.mid_axillary->z;
  }
  for (const palp::TrunkIntercostalSpace& s : truth.intercostal_spaces)
    if (s.side == palp::TrunkSide::right && s.upper_rib == 9) target = s.skin_point->z;
  const double z = target + up_mm;
  EXPECT_GT(z9, target);
  EXPECT_LT(z10, target);
  if (std::fabs(z - z9) <= palp::training::kRibHalfWidthMm) return "rib 9";
  return z > z9 ? "space 8/9" : "target";
}

// Where a mark `up_mm` superior of the L3/L4 interspace's point lies, from the truth's spinous
// tips of L2 and L3 (within 7.5 mm of a tip's level is on it).
std::string lumbar_expected(double up_mm) {
  const palp::TrunkTruth truth = palp::trunk_truth();
  double z2 = 0.0, z3 = 0.0, target = 0.0;
  for (const palp::TrunkVertebra& v : truth.vertebrae) {
    if (v.name == "L2") z2 = v.spinous_tip->z;
    if (v.name == "L3") z3 = v.spinous_tip->z;
  }
  for (const palp::TrunkLumbarInterspace& l : truth.lumbar_interspaces)
    if (l.name == "L3/L4") target = l.skin_point.z;
  const double z = target + up_mm;
  if (std::fabs(z - z3) <= palp::training::kSpinousHalfHeightMm) return "spinous process L3";
  if (std::fabs(z - z2) <= palp::training::kSpinousHalfHeightMm) return "spinous process L2";
  return z > z2 ? "L1/L2" : z > z3 ? "L2/L3" : "target";
}

TEST(CmdTrajSearch, PtcdRightNinthSpaceAndAMarkTwentyMillimetresAbove) {
  const auto rows =
      search_and_score("ptcd", "--task ptcd --side right --space 9", "ptcd --side right --space 9");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].where, "target");
  EXPECT_TRUE(rows[0].in_target);
  EXPECT_LT(rows[0].distance_mm, 3.0);
  // The mark lies where the finger's pad held the skin: a few mm behind the finger after a short
  // slide (the friction proxies trail it), so its place is judged at its own distance.
  EXPECT_GT(rows[1].distance_mm, 18.0);
  EXPECT_LT(rows[1].distance_mm, 27.0);
  EXPECT_EQ(rows[1].where, ptcd_expected(rows[1].distance_mm));
  EXPECT_FALSE(rows[1].in_target);
}

TEST(CmdTrajSearch, LumbarL3L4AndAMarkTwentyMillimetresAbove) {
  const auto rows =
      search_and_score("lumbar", "--task lumbar --interspace L3/L4", "lumbar --interspace L3/L4");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].where, "target");
  EXPECT_LT(rows[0].distance_mm, 3.0);
  EXPECT_GT(rows[1].distance_mm, 18.0);
  EXPECT_LT(rows[1].distance_mm, 27.0);
  EXPECT_EQ(rows[1].where, lumbar_expected(rows[1].distance_mm));
  EXPECT_FALSE(rows[1].in_target);
}

TEST(CmdTrajSearch, FemoralLeftAndAMarkTwentyMillimetresAbove) {
  const auto rows =
      search_and_score("femoral", "--task femoral --side left", "femoral --side left");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].where, "target");
  EXPECT_LT(rows[0].distance_mm, 3.0);
  EXPECT_GT(rows[1].distance_mm, palp::training::kFemoralPulseRadiusMm);
  EXPECT_EQ(rows[1].where, "off the pulse");
}

// The whole chain on the phantom: palp landmarks finds the landmarks, the trainee searches with
// them, and palp task scores the run against the truth: the detected interspace and pulse point
// are the truth's.
TEST(CmdTrajSearch, DetectedLandmarksLeadTheTraineeToTheTruthsTarget) {
  const fs::path dir = shared_cli_dir() / "detected";
  fs::create_directories(dir);
  const std::string detected = (dir / "landmarks.json").string();
  const auto l = run_palp_cli("landmarks phantom:trunk -q --out " + detected, cache());
  ASSERT_EQ(l.exit_code, 0) << l.output;
  for (const std::string task :
       {"ptcd --side right --space 9", "lumbar --interspace L3/L4", "femoral --side right"}) {
    const std::string traj = (dir / "run.csv").string(), marks = (dir / "marks.csv").string();
    const std::string csv = (dir / "cohort.csv").string();
    fs::remove(csv);
    const auto r =
        run_palp_cli("traj search -q --rate 200" + kTrunkScene + " --task " + task +
                         " --landmarks " + detected + " --out " + traj + " --marks " + marks,
                     cache());
    ASSERT_EQ(r.exit_code, 0) << task << "\n" << r.output;
    const auto t =
        run_palp_cli("task " + task + " -q" + kTrunkScene + " --landmarks " + trunk_landmarks() +
                         " --trajectory " + traj + " --marks " + marks + " --csv " + csv,
                     cache());
    ASSERT_EQ(t.exit_code, 0) << task << "\n" << t.output;
    std::ifstream in(csv);
    std::string header, row;
    std::getline(in, header), std::getline(in, row);
    const ScoredRow scored = scored_row(row);
    EXPECT_EQ(scored.where, "target") << task << "\n" << row;
    EXPECT_LT(scored.distance_mm, 4.0) << task << "\n" << row;

    // Without --landmarks palp task finds them in the scene: the same score as with the file
    // palp landmarks wrote (to the file's 0.01 mm); once, the runs take seconds each.
    if (task.rfind("lumbar", 0) != 0) continue;
    std::string rows[2];
    for (int found = 0; found < 2; ++found) {
      fs::remove(csv);
      const auto s = run_palp_cli("task " + task + " -q" + kTrunkScene +
                                      (found ? "" : " --landmarks " + detected) +
                                      " --trajectory " + traj + " --marks " + marks +
                                      " --csv " + csv + " --session same",
                                  cache());
      ASSERT_EQ(s.exit_code, 0) << task << "\n" << s.output;
      std::ifstream again(csv);
      std::getline(again, header), std::getline(again, rows[found]);
    }
    const ScoredRow with_file = scored_row(rows[0]), found = scored_row(rows[1]);
    EXPECT_EQ(found.where, with_file.where) << rows[1];
    EXPECT_NEAR(found.distance_mm, with_file.distance_mm, 0.02) << rows[1];
  }
}

TEST(CmdTrajSearch, TheSameBytesTwiceAndOneLineMistakes) {
  const std::string common = kTrunkScene + " --landmarks " + trunk_landmarks();
  const fs::path traj = shared_cli_dir() / "s.csv", marks = shared_cli_dir() / "s_marks.csv";
  const std::string args = "traj search --task ptcd --space 10 --miss -13,0 --rate 200" + common +
                           " --out " + traj.string() + " --marks " + marks.string();
  ASSERT_EQ(run_palp_cli(args, cache()).exit_code, 0);
  const std::string first = read_text(traj), first_marks = read_text(marks);
  ASSERT_EQ(run_palp_cli(args + " -q", cache()).exit_code, 0);
  EXPECT_EQ(read_text(traj), first);
  EXPECT_EQ(read_text(marks), first_marks);
  EXPECT_EQ(first_marks.rfind("trial,t\n1,", 0), 0u) << first_marks;
  EXPECT_EQ(count_lines(first_marks), 3);

  const std::string out = " --out " + (shared_cli_dir() / "w.csv").string();
  struct Case {
    std::string args;
    int code;
    std::string says;
  } cases[] = {
      {"traj search" + common + out, 2, "--task"},
      {"traj search --task knee" + common + out, 2, "unknown task 'knee'"},
      {"traj search --task ptcd --side middle" + common + out, 2, "right or left"},
      {"traj search --task lumbar --space 9" + common + out, 2, "--space is for ptcd"},
      {"traj search --task lumbar --side left" + common + out, 2, "midline"},
      {"traj search --task ptcd --miss 1,,2" + common + out, 2, "--miss"},
      {"traj search --task ptcd --scene phantom:trunk" + out, 2, "--landmarks"},
      {"traj search --task ptcd --space 11" + common + out, 1, "11"},
      {"traj search --task ptcd --scene phantom:cube --landmarks " + trunk_landmarks() + out, 1,
       "not within 10 mm"},
  };
  for (const Case& c : cases) {
    const auto r = run_palp_cli(c.args, cache());
    EXPECT_EQ(r.exit_code, c.code) << c.args << "\n" << r.output;
    EXPECT_NE(last_line(r.output).find(c.says), std::string::npos) << c.args << "\n" << r.output;
  }
}

}  // namespace
