// Where a mark lies in a task's anatomy (task.hpp classify): which rib or intercostal space, which
// lumbar interspace or spinous process, on or off the femoral pulse. Every comparison is made in
// the task's view (task_view): superior-inferior is the view's `up` coordinate.
//   ptcd:    each numbered rib of a side -> its centre line's `up` at the mark's `across`
//            -> on a rib (within kRibHalfWidthMm) or between the ribs above and below
//   lumbar:  the named spinous tips -> on a tip (within kSpinousHalfHeightMm) or between two,
//            and how far off the midline
//   femoral: the distance to the pulse point against the target's radius
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "training/task.hpp"

namespace palp::training {
namespace {

using anatomy::Side;

// A rib's or tip's superior-inferior level at the mark: `offset` = mark's up minus the level's
// (positive: the mark is superior to it).
struct Level {
  std::string name;
  double offset = 0.0;
  double across = 0.0;  // the landmark's across coordinate there (tips: the midline)
};

// The `up` of a rib's centre line where its view projection crosses the mark's `across`: over
// the rib's segments that span it, the crossing nearest to the mark in 3D (a rib seen from the
// side folds back near its head). Empty when the rib does not reach the mark's across.
std::optional<double> rib_level_at(const anatomy::Rib& rib, const TaskView& view,
                                   const Vec3d& mark) {
  const double a = project(view, mark).across;
  std::optional<double> best;
  double best_distance = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < rib.points.size(); ++i) {
    const ViewPoint p0 = project(view, rib.points[i]);
    const ViewPoint p1 = project(view, rib.points[i + 1]);
    const double lo = std::min(p0.across, p1.across), hi = std::max(p0.across, p1.across);
    if (a < lo || a > hi) continue;
    const double span = p1.across - p0.across;
    const double f = std::abs(span) > 1e-9 ? (a - p0.across) / span : 0.5;
    const Vec3d at = rib.points[i] + f * (rib.points[i + 1] - rib.points[i]);
    const double distance = norm(at - mark);
    if (distance < best_distance) {
      best_distance = distance;
      best = p0.up + f * (p1.up - p0.up);
    }
  }
  return best;
}

// The patient's midline as an LPS x, from the vertebrae, else from the two sides' ribs; empty
// when neither is in the landmarks.
std::optional<double> midline_x(const anatomy::Landmarks& landmarks) {
  double sum = 0.0;
  for (const auto& v : landmarks.vertebrae) sum += v.body_centre.x;
  if (!landmarks.vertebrae.empty()) return sum / static_cast<double>(landmarks.vertebrae.size());
  double side_sum[2] = {0.0, 0.0};
  std::size_t side_count[2] = {0, 0};
  for (const auto& rib : landmarks.ribs) {
    const int s = rib.side == Side::right ? 0 : 1;
    for (const Vec3d& p : rib.points) side_sum[s] += p.x, ++side_count[s];
  }
  if (side_count[0] == 0 || side_count[1] == 0) return std::nullopt;
  return 0.5 * (side_sum[0] / static_cast<double>(side_count[0]) +
                side_sum[1] / static_cast<double>(side_count[1]));
}

// The side of the patient `point` is on (LPS x grows to the left); `fallback` without a midline.
Side side_of(const anatomy::Landmarks& landmarks, const Vec3d& point, Side fallback) {
  const auto mid = midline_x(landmarks);
  if (!mid || point.x == *mid) return fallback;
  return point.x > *mid ? Side::left : Side::right;
}

// The nearest level on (|offset| <= half) and the nearest above (offset < 0: the level is
// superior to the mark) and below the mark.
struct Bracket {
  const Level* on = nullptr;
  const Level* above = nullptr;
  const Level* below = nullptr;
};
Bracket bracket(const std::vector<Level>& levels, double half) {
  Bracket b;
  for (const Level& level : levels) {
    if (std::abs(level.offset) <= half &&
        (!b.on || std::abs(level.offset) < std::abs(b.on->offset)))
      b.on = &level;
    if (level.offset < 0.0 && (!b.above || level.offset > b.above->offset)) b.above = &level;
    if (level.offset > 0.0 && (!b.below || level.offset < b.below->offset)) b.below = &level;
  }
  return b;
}

Placement classify_ptcd(const TaskTarget& target, const anatomy::Landmarks& landmarks,
                        const Vec3d& point) {
  const TaskView view = task_view(target);
  const Side side = side_of(landmarks, point, target.spec.side);
  const double up = project(view, point).up;
  std::vector<Level> levels;
  for (const auto& rib : landmarks.ribs) {
    if (rib.side != side || !rib.number) continue;
    if (const auto level = rib_level_at(rib, view, point))
      levels.push_back({std::to_string(*rib.number), up - *level, 0.0});
  }
  const std::string prefix =
      side == target.spec.side ? "" : std::string(anatomy::side_name(side)) + " side, ";
  if (levels.empty()) return {prefix + "no rib at this position", false};
  const Bracket b = bracket(levels, kRibHalfWidthMm);
  if (b.on) return {prefix + "rib " + b.on->name, false};
  if (b.above && b.below) {
    const int upper = std::stoi(b.above->name), lower = std::stoi(b.below->name);
    const bool hit = prefix.empty() && upper == target.spec.space && lower == upper + 1;
    return {hit ? "target" : prefix + "space " + b.above->name + "/" + b.below->name, hit};
  }
  if (b.above) return {prefix + "below rib " + b.above->name, false};
  return {prefix + "above rib " + b.below->name, false};
}

// The interspace's name from its two vertebrae: the sacrum ("S") is S1 there.
std::string interspace_name(const std::string& upper, const std::string& lower) {
  return upper + "/" + (lower == "S" ? std::string("S1") : lower);
}

// The named spinous tips as levels at `point`; the sacrum (no tip) by its L5/S1 interspace point
// mirrored about L5's tip, when the landmarks have both.
std::vector<Level> tip_levels(const anatomy::Landmarks& landmarks, const TaskView& view,
                              const ViewPoint& mark) {
  std::vector<Level> levels;
  for (const auto& v : landmarks.vertebrae) {
    if (!v.name || !v.spinous_tip) continue;
    const ViewPoint tip = project(view, *v.spinous_tip);
    levels.push_back({*v.name, mark.up - tip.up, tip.across});
  }
  const auto* l5 = anatomy::find_vertebra(landmarks, "L5");
  const auto* sacrum = anatomy::find_vertebra(landmarks, "S");
  const auto* l5s1 = anatomy::find_lumbar_interspace(landmarks, "L5/S1");
  if (l5 && l5->spinous_tip && (!sacrum || !sacrum->spinous_tip) && l5s1 && l5s1->skin_point) {
    const ViewPoint tip = project(view, *l5->spinous_tip);
    const ViewPoint gap = project(view, *l5s1->skin_point);
    levels.push_back({"S", mark.up - (2.0 * gap.up - tip.up), 2.0 * gap.across - tip.across});
  }
  return levels;
}

Placement classify_lumbar(const TaskTarget& target, const anatomy::Landmarks& landmarks,
                          const Vec3d& point) {
  const TaskView view = task_view(target);
  const ViewPoint mark = project(view, point);
  const std::vector<Level> levels = tip_levels(landmarks, view, mark);
  if (levels.empty()) return {"no spinous process in the landmarks", false};
  const Bracket b = bracket(levels, kSpinousHalfHeightMm);
  if (b.on) return {"spinous process " + b.on->name, false};
  if (!b.above) return {"above " + b.below->name, false};
  if (!b.below) return {"below " + b.above->name, false};
  // The midline at the mark's level: the line between the two tips.
  const double span = b.below->offset - b.above->offset;  // > 0
  const double f = -b.above->offset / span;
  const double midline = b.above->across + f * (b.below->across - b.above->across);
  const double off = mark.across - midline;
  const std::string name = interspace_name(b.above->name, b.below->name);
  const bool on_midline = std::abs(off) <= kMidlineToleranceMm;
  const bool hit = on_midline && name == target.spec.interspace;
  if (hit) return {"target", true};
  if (on_midline) return {name, false};
  char text[64];
  std::snprintf(text, sizeof text, ", %.0f mm off the midline", std::abs(off));
  return {name + text, false};
}

Placement classify_femoral(const TaskTarget& target, const anatomy::Landmarks& landmarks,
                           const Vec3d& point) {
  const double radius = target.radius_mm > 0.0 ? target.radius_mm : kFemoralPulseRadiusMm;
  if (norm(point - target.point) <= radius) return {"target", true};
  for (const auto& pulse : landmarks.femoral_pulse_points) {
    if (pulse.side == target.spec.side || !pulse.skin_point) continue;
    if (norm(point - *pulse.skin_point) <= radius)
      return {std::string("the ") + anatomy::side_name(pulse.side) + " pulse", false};
  }
  return {"off the pulse", false};
}

}  // namespace

Placement classify(const TaskTarget& target, const anatomy::Landmarks& landmarks,
                   const Vec3d& point) {
  switch (target.spec.kind) {
    case TaskKind::ptcd:
      return classify_ptcd(target, landmarks, point);
    case TaskKind::lumbar:
      return classify_lumbar(target, landmarks, point);
    case TaskKind::femoral:
      return classify_femoral(target, landmarks, point);
  }
  return {};
}

}  // namespace palp::training
