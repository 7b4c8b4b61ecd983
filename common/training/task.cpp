// Training tasks: the spec, its target in the landmarks, and a trial's score (task.hpp).
//   TaskSpec -> resolve_target (landmarks) -> TaskTarget
//   samples + marks -> metrics (path, contact time, force) + each mark classified (placement.cpp)
#include "training/task.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "base/errors.hpp"

namespace palp::training {
namespace {

using anatomy::Side;

// "L3" -> 3; "S1" -> 6 (the level below L5); anything else -> 0.
int lumbar_level(std::string_view name) {
  if (name == "S1") return 6;
  if (name.size() != 2 || name[0] != 'L') return 0;
  const int n = name[1] - '0';
  return n >= 1 && n <= 5 ? n : 0;
}

// The outward normal a task's target faces when the landmarks carry none: the side's lateral for
// ptcd, posterior for lumbar, anterior for femoral (LPS: +x left, +y posterior).
Vec3d default_normal(const TaskSpec& spec) {
  switch (spec.kind) {
    case TaskKind::ptcd:
      return spec.side == Side::right ? Vec3d{-1.0, 0.0, 0.0} : Vec3d{1.0, 0.0, 0.0};
    case TaskKind::lumbar:
      return {0.0, 1.0, 0.0};
    case TaskKind::femoral:
      return {0.0, -1.0, 0.0};
  }
  return {0.0, 0.0, 1.0};
}

// Fills the target's point and normal; a missing or degenerate normal falls back with a note.
void place(TaskTarget& target, const Vec3d& point, const std::optional<Vec3d>& normal) {
  target.point = point;
  const double length = normal ? norm(*normal) : 0.0;
  if (normal && is_finite(*normal) && length > 1e-9) {
    target.normal = *normal * (1.0 / length);
  } else {
    target.normal = default_normal(target.spec);
    target.notes.push_back("the landmarks carry no skin normal at the target: the " +
                           std::string(target.spec.kind == TaskKind::ptcd     ? "lateral"
                                       : target.spec.kind == TaskKind::lumbar ? "posterior"
                                                                              : "anterior") +
                           " direction is used");
  }
}

std::string why(const std::string& reason) {
  return reason.empty() ? std::string() : " (" + reason + ")";
}

void resolve_ptcd(TaskTarget& target, const anatomy::Landmarks& landmarks) {
  const TaskSpec& spec = target.spec;
  const std::string name = std::string(anatomy::side_name(spec.side)) + " intercostal space " +
                           std::to_string(spec.space) + "/" + std::to_string(spec.space + 1);
  const auto* space = anatomy::find_intercostal_space(landmarks, spec.side, spec.space);
  if (!space) throw InputError("the landmarks have no " + name);
  if (!space->skin_point)
    throw InputError("the landmarks cannot place the " + name + why(space->reason));
  place(target, *space->skin_point, space->normal);
  for (const int rib : {spec.space, spec.space + 1}) {
    if (!anatomy::find_rib(landmarks, spec.side, rib))
      target.notes.push_back("rib " + std::to_string(rib) + " on the " +
                             anatomy::side_name(spec.side) +
                             " is not in the landmarks: no mark can be placed between the ribs");
  }
}

void resolve_lumbar(TaskTarget& target, const anatomy::Landmarks& landmarks) {
  const std::string& name = target.spec.interspace;
  const auto* interspace = anatomy::find_lumbar_interspace(landmarks, name);
  if (!interspace) throw InputError("the landmarks have no lumbar interspace " + name);
  if (!interspace->skin_point)
    throw InputError("the landmarks cannot place the interspace " + name + why(interspace->reason));
  place(target, *interspace->skin_point, interspace->normal);
}

void resolve_femoral(TaskTarget& target, const anatomy::Landmarks& landmarks) {
  const Side side = target.spec.side;
  const auto* pulse = anatomy::find_femoral_pulse_point(landmarks, side);
  const std::string name = std::string(anatomy::side_name(side)) + " femoral pulse point";
  if (!pulse) throw InputError("the landmarks have no " + name);
  if (!pulse->skin_point)
    throw InputError("the landmarks cannot place the " + name + why(pulse->reason));
  place(target, *pulse->skin_point, pulse->normal);
  target.radius_mm = kFemoralPulseRadiusMm;
  target.pulse_felt = pulse->source == "artery";
  if (!target.pulse_felt)
    target.notes.push_back(
        "no artery in this scan: the pulse is not felt; the target is the " +
        (pulse->source.empty() ? std::string("landmarks' point") : pulse->source + " point") +
        " from the bones");
}

void check_finite(const Vec3d& v, const char* what) {
  if (!is_finite(v)) throw InputError(std::string("a trial's ") + what + " is not finite");
}

void check_samples(const std::vector<TrialSample>& samples) {
  if (samples.size() > kMaxTrialSamples)
    throw InputError("a trial of " + std::to_string(samples.size()) + " samples is more than " +
                     std::to_string(kMaxTrialSamples) + " (ten minutes at 1 kHz)");
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const TrialSample& s = samples[i];
    if (!std::isfinite(s.t) || !std::isfinite(s.normal_force))
      throw InputError("trial sample " + std::to_string(i) + " has a non-finite time or force");
    check_finite(s.device_point, "device point");
    check_finite(s.skin_point, "skin point");
    if (i > 0 && s.t < samples[i - 1].t)
      throw InputError("trial samples are not in time order at sample " + std::to_string(i));
  }
}

// The metrics of task.hpp from the samples alone.
void add_metrics(TrialScore& score, const std::vector<TrialSample>& samples) {
  double force_sum = 0.0;
  std::size_t contact_samples = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const TrialSample& s = samples[i];
    score.peak_force_n = std::max(score.peak_force_n, s.normal_force);
    if (!s.in_contact) continue;
    force_sum += s.normal_force;
    ++contact_samples;
    if (i + 1 < samples.size()) score.time_in_contact_s += samples[i + 1].t - s.t;
    if (i > 0 && samples[i - 1].in_contact)
      score.path_length_mm += norm(s.skin_point - samples[i - 1].skin_point);
  }
  if (contact_samples > 0) score.mean_force_n = force_sum / static_cast<double>(contact_samples);
  if (!samples.empty()) score.duration_s = samples.back().t - samples.front().t;
}

}  // namespace

const char* task_kind_name(TaskKind kind) {
  switch (kind) {
    case TaskKind::ptcd:
      return "ptcd";
    case TaskKind::lumbar:
      return "lumbar";
    case TaskKind::femoral:
      return "femoral";
  }
  return "?";
}

std::optional<TaskKind> parse_task_kind(std::string_view text) {
  for (const TaskKind kind : {TaskKind::ptcd, TaskKind::lumbar, TaskKind::femoral})
    if (text == task_kind_name(kind)) return kind;
  return std::nullopt;
}

std::string describe(const TaskSpec& spec) {
  const std::string kind = task_kind_name(spec.kind);
  switch (spec.kind) {
    case TaskKind::ptcd:
      return kind + " " + anatomy::side_name(spec.side) + " " + std::to_string(spec.space) + "/" +
             std::to_string(spec.space + 1);
    case TaskKind::lumbar:
      return kind + " " + spec.interspace;
    case TaskKind::femoral:
      return kind + " " + anatomy::side_name(spec.side);
  }
  return kind;
}

void validate(const TaskSpec& spec) {
  if (spec.kind == TaskKind::ptcd && (spec.space < 1 || spec.space > 11))
    throw UsageError("an intercostal space is 1..11 (the space below that rib), got " +
                     std::to_string(spec.space));
  if (spec.kind == TaskKind::lumbar) {
    const std::string_view text = spec.interspace;
    const auto slash = text.find('/');
    const int upper = slash == std::string_view::npos ? 0 : lumbar_level(text.substr(0, slash));
    const int lower = slash == std::string_view::npos ? 0 : lumbar_level(text.substr(slash + 1));
    if (upper < 1 || upper > 5 || lower != upper + 1)
      throw UsageError("a lumbar interspace is L1/L2, L2/L3, L3/L4, L4/L5 or L5/S1, got '" +
                       spec.interspace + "'");
  }
}

TaskTarget resolve_target(const TaskSpec& spec, const anatomy::Landmarks& landmarks) {
  validate(spec);
  TaskTarget target;
  target.spec = spec;
  switch (spec.kind) {
    case TaskKind::ptcd:
      resolve_ptcd(target, landmarks);
      break;
    case TaskKind::lumbar:
      resolve_lumbar(target, landmarks);
      break;
    case TaskKind::femoral:
      resolve_femoral(target, landmarks);
      break;
  }
  check_finite(target.point, "target point");
  return target;
}

TaskView task_view(const TaskTarget& target) {
  TaskView view;
  view.origin = target.point;
  const double n_length = norm(target.normal);
  view.normal = n_length > 1e-9 ? target.normal * (1.0 / n_length) : Vec3d{0.0, 0.0, 1.0};
  // Superior made perpendicular to the normal; a normal along superior (a vertex view) takes
  // anterior (-y in LPS) as up instead.
  for (const Vec3d& wanted : {Vec3d{0.0, 0.0, 1.0}, Vec3d{0.0, -1.0, 0.0}}) {
    const Vec3d up = wanted - dot(wanted, view.normal) * view.normal;
    if (norm(up) > 1e-3) {
      view.up = up * (1.0 / norm(up));
      break;
    }
  }
  view.across = cross(view.up, view.normal);
  return view;
}

ViewPoint project(const TaskView& view, const Vec3d& point) {
  const Vec3d d = point - view.origin;
  return {dot(d, view.across), dot(d, view.up)};
}

Mark mark_at(const std::vector<TrialSample>& samples, double t) {
  if (samples.empty()) throw InputError("a mark needs the trial's samples to place it");
  if (!std::isfinite(t)) throw InputError("a mark's time is not finite");
  // The last sample with sample.t <= t.
  const auto after = std::upper_bound(samples.begin(), samples.end(), t,
                                      [](double time, const TrialSample& s) { return time < s.t; });
  const TrialSample& at = after == samples.begin() ? samples.front() : *(after - 1);
  return Mark{t, at.skin_point};
}

TrialScore score_trial(const TaskTarget& target, const anatomy::Landmarks& landmarks,
                       const std::vector<TrialSample>& samples, const std::vector<Mark>& marks) {
  check_samples(samples);
  if (marks.size() > kMaxTrialMarks)
    throw InputError("a trial of " + std::to_string(marks.size()) + " marks is more than " +
                     std::to_string(kMaxTrialMarks));
  for (const Mark& mark : marks) {
    if (!std::isfinite(mark.t)) throw InputError("a mark's time is not finite");
    check_finite(mark.point, "mark");
  }
  TrialScore score;
  add_metrics(score, samples);
  std::vector<Mark> ordered = marks;
  std::stable_sort(ordered.begin(), ordered.end(),
                   [](const Mark& a, const Mark& b) { return a.t < b.t; });
  if (!ordered.empty()) score.time_to_first_mark_s = ordered.front().t;
  for (const Mark& mark : ordered) {
    const Placement placement = classify(target, landmarks, mark.point);
    score.marks.push_back(
        MarkScore{mark, norm(mark.point - target.point), placement.in_target, placement.where});
  }
  return score;
}

}  // namespace palp::training
