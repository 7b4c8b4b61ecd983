// Training tasks on the patient's own anatomy (issue 40): what the trainee looks for, where it
// is (from the scan's landmarks), and how a trial is scored. Pure: no files, no clocks, no
// threads; palp task (offline, from a trajectory) and palpd (live, from the loop's published
// snapshots) both feed it samples and marks and get the same scores.
//
// Frames: every point here is in the patient's LPS world frame (mm), like the landmarks; callers
// convert from the scene frame with the grid's placement.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "anatomy/landmarks.hpp"
#include "base/vec.hpp"

namespace palp::training {

enum class TaskKind { ptcd, lumbar, femoral };
const char* task_kind_name(TaskKind kind);  // "ptcd", "lumbar", "femoral"
std::optional<TaskKind> parse_task_kind(std::string_view text);

// What the instructor asks for. ptcd: the intercostal space below rib `space` on `side` at the
// mid-axillary line (default the 9th/10th on the right). lumbar: the interspace `interspace`
// ("L3/L4" or "L4/L5") on the midline. femoral: the femoral pulse point on `side`.
struct TaskSpec {
  TaskKind kind = TaskKind::ptcd;
  anatomy::Side side = anatomy::Side::right;
  int space = 9;
  std::string interspace = "L3/L4";
};
// "ptcd right 9/10", "lumbar L3/L4", "femoral left": for reports, HUDs and logs.
std::string describe(const TaskSpec& spec);
// Throws UsageError for a space outside 1..11, an interspace that is not Ln/Ln+1 within L1..S1.
void validate(const TaskSpec& spec);

// Where the target is: the skin point and outward normal, and what a mark must lie between to
// be "in the target" (the two ribs, the two spinous processes, or within `radius_mm` of the
// pulse point). Resolved from the landmarks once, when the task starts.
struct TaskTarget {
  TaskSpec spec;
  Vec3d point{};
  Vec3d normal{};
  double radius_mm = 0.0;  // femoral: a mark within this is on the pulse
  std::vector<std::string> notes;  // e.g. "no artery in this scan: the pulse is not felt"
  bool pulse_felt = false;         // femoral: the scene has an artery layer that pulses
};
// The target for `spec` in `landmarks`. Throws InputError with the landmarks' reason when the
// scan does not show it (rib 9 not numbered, no L3/L4, no femoral point on that side).
TaskTarget resolve_target(const TaskSpec& spec, const anatomy::Landmarks& landmarks);

// One observation of the trainee's finger, at the loop's publication rate or a trajectory's row.
struct TrialSample {
  double t = 0.0;         // s since the trial started
  Vec3d device_point{};   // LPS mm
  Vec3d skin_point{};     // LPS mm: the contact proxies' mean (on the skin); = device_point out of contact
  double normal_force = 0.0;  // N, the pressing force
  bool in_contact = false;
};

// A mark: the trainee says "here" (a device button, a key, `palp ctl … task mark`).
struct Mark {
  double t = 0.0;    // s since the trial started
  Vec3d point{};     // LPS mm, the skin point at that moment
};

// Where a mark landed, in the task's anatomy: "target" (the asked space), or what else it is
// on ("rib 9", "space 8/9", "L2/L3", "spinous process L4", "off the pulse") — from the landmarks.
struct MarkScore {
  Mark mark;
  double distance_mm = 0.0;  // to the target point
  bool in_target = false;
  std::string where;
};

struct TrialScore {
  std::vector<MarkScore> marks;   // in order; the last one is the trial's answer
  std::optional<double> time_to_first_mark_s;
  double peak_force_n = 0.0;
  double mean_force_n = 0.0;      // over samples in contact
  double path_length_mm = 0.0;    // of the skin point while in contact
  double time_in_contact_s = 0.0;
  double duration_s = 0.0;
};

// Scores one trial. Samples must be in time order (InputError otherwise); marks need not lie on
// sample times.
TrialScore score_trial(const TaskTarget& target, const anatomy::Landmarks& landmarks,
                       const std::vector<TrialSample>& samples, const std::vector<Mark>& marks);

}  // namespace palp::training
