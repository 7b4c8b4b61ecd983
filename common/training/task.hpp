// Training tasks on the patient's own anatomy (issue 40): what the trainee looks for, where it
// is (from the scan's landmarks), and how a trial is scored. Pure: no files, no clocks, no
// threads; palp task (offline, from a trajectory) and palpd (live, from the loop's published
// snapshots) both feed it samples and marks and get the same scores.
//
// Frames: every point here is in the patient's LPS world frame (mm), like the landmarks; callers
// convert from the scene frame with the grid's placement.
#pragma once

#include <cstddef>
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

// --- Added by the task implementation (task.cpp); docs/tasks.md defines each. ---

// The metrics, sample by sample i (docs/tasks.md "Metrics"): path_length_mm sums
// |skin_point[i] - skin_point[i-1]| over consecutive samples both in contact; time_in_contact_s
// sums t[i+1] - t[i] over samples i in contact (the interval a sample begins); peak_force_n is the
// largest normal_force, mean_force_n its mean over samples in contact; duration_s is the last
// sample's t minus the first's; time_to_first_mark_s the earliest mark's t. Marks are scored in
// time order (a stable sort by t).

// Bounds score_trial enforces (InputError beyond them): ten minutes at 1 kHz, 1000 marks.
inline constexpr std::size_t kMaxTrialSamples = 600000;
inline constexpr std::size_t kMaxTrialMarks = 1000;

// The classification's anatomy (docs/tasks.md "Where a mark lies"):
// a rib's half width about its centre line (ribs are 10-15 mm wide at the mid-axillary line):
// a mark within this of a rib's centre line, superior-inferior, is on the rib ("rib 9");
inline constexpr double kRibHalfWidthMm = 6.0;
// a spinous process's tip, half its superior-inferior height (lumbar tips are ~15 mm tall);
inline constexpr double kSpinousHalfHeightMm = 7.5;
// how far from the midline (the line through the spinous tips) a lumbar mark may lie and still be
// in the target (a midline needle enters within a few millimetres of it);
inline constexpr double kMidlineToleranceMm = 10.0;
// femoral: the common femoral artery is ~8-10 mm across (radius ~4.5 mm) and a fingertip's pad
// ~15 mm wide (half 7.5 mm): a pad centred within 12 mm of the pulse point lies over the lumen.
inline constexpr double kFemoralPulseRadiusMm = 12.0;

// The view from the task's side: origin at the target point, `normal` the target's outward
// normal (towards the viewer), `up` the patient's superior projected perpendicular to it,
// `across` = up x normal (the viewer's right, looking at the skin). Reports draw in it; ptcd
// and lumbar classify marks by their `up` coordinate against the ribs' and tips'.
struct TaskView {
  Vec3d origin{};
  Vec3d normal{0.0, 0.0, 1.0};
  Vec3d up{0.0, 1.0, 0.0};
  Vec3d across{1.0, 0.0, 0.0};
};
TaskView task_view(const TaskTarget& target);
struct ViewPoint {
  double across = 0.0;  // mm
  double up = 0.0;      // mm
};
ViewPoint project(const TaskView& view, const Vec3d& point);

// The mark at time t of a trial: the skin point of the last sample at or before t (the first
// sample when t precedes them all). InputError for no samples or a non-finite t.
Mark mark_at(const std::vector<TrialSample>& samples, double t);

// Where `point` lies in the task's anatomy, as MarkScore::where and in_target: the
// classification score_trial gives each mark.
struct Placement {
  std::string where;
  bool in_target = false;
};
Placement classify(const TaskTarget& target, const anatomy::Landmarks& landmarks,
                   const Vec3d& point);

}  // namespace palp::training
