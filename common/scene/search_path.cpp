// The search path of search_path.hpp: a walk over the skin from the target toward superior and
// inferior, then the trials' phases timed row by row along it.
//
//   target (LPS) -> scene frame -> onto the skin -> walk table (skin points, normals, every
//   kSearchStepMm of arc) -> per trial: approach, slide, hold, lift, transfer -> rows, marks
#include "scene/search_path.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <string>

#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "scene/path_geometry.hpp"
#include "scene/trajectory_gen.hpp"

namespace palp {

using namespace path_geometry;

namespace {

// Newton steps back onto the skin, and how far off the skin a landmark may lie (mm).
constexpr int kProjectionSteps = 8;
constexpr double kMaxTargetOffSkinMm = 10.0;

std::string mm_text(const Vec3d& p) {
  char text[96];
  std::snprintf(text, sizeof text, "(%.1f, %.1f, %.1f)", p.x, p.y, p.z);
  return text;
}

// The point moved onto D_surf = 0 along the outward normal `n` (D > 0 inside: move out by D).
Vec3d onto_skin(const FieldSampler& fields, Vec3d p, const Vec3d& n) {
  for (int i = 0; i < kProjectionSteps; ++i) {
    const FieldSample s = fields.sample_surf(p);
    if (!s.inside) break;
    if (std::fabs(s.value) < 1e-9) break;
    p += s.value * n;
  }
  return p;
}

// The skin along the walk: points and patch normals every kSearchStepMm, from `lo` steps
// (inferior, negative) to `hi` steps (superior) of the target.
struct SkinWalk {
  std::vector<Vec3d> points, normals;
  int lo = 0;
  Vec3d superior{};

  // The skin frame at arc length s (mm, + = superior), linear between the table's steps.
  SkinFrame at(double s) const {
    const double k = std::clamp(s / kSearchStepMm, static_cast<double>(lo),
                                static_cast<double>(lo + static_cast<int>(points.size()) - 1));
    const auto i = static_cast<std::size_t>(std::floor(k - lo));
    const std::size_t j = std::min(i + 1, points.size() - 1);
    const double f = (k - lo) - static_cast<double>(i);
    SkinFrame frame;
    frame.skin = (1.0 - f) * points[i] + f * points[j];
    frame.normal = unit((1.0 - f) * normals[i] + f * normals[j]);
    frame.slide = superior;
    return frame;
  }
};

// One step of the walk from `p` (normal `n`) toward `sign` * superior on the tangent plane.
void walk_step(const FieldSampler& fields, const Vec3d& superior, double sign, Vec3d* p, Vec3d* n) {
  const Vec3d tangent = unit(superior - dot(superior, *n) * *n);
  if (norm(tangent) == 0.0)
    throw InputError("search path: the skin faces superior at " + mm_text(*p));
  const Vec3d next = onto_skin(fields, *p + (sign * kSearchStepMm) * tangent, *n);
  const Vec3d normal = patch_normal(fields, next, superior);
  if (norm(normal) == 0.0 || !fields.sample_surf(next).inside)
    throw InputError("search path: the walk over the skin leaves the scene at " + mm_text(next));
  *p = next;
  *n = normal;
}

SkinWalk walk_skin(const FieldSampler& fields, const Vec3d& target, const Vec3d& target_normal,
                   double lo_mm, double hi_mm) {
  SkinWalk walk;
  walk.superior = patient_frame(fields.grid()).superior;
  walk.lo = static_cast<int>(std::floor(lo_mm / kSearchStepMm)) - 1;
  const int hi = static_cast<int>(std::ceil(hi_mm / kSearchStepMm)) + 1;
  std::vector<Vec3d> up{target}, up_n{target_normal}, down, down_n;
  Vec3d p = target, n = target_normal;
  for (int k = 1; k <= hi; ++k) {
    walk_step(fields, walk.superior, 1.0, &p, &n);
    up.push_back(p), up_n.push_back(n);
  }
  p = target, n = target_normal;
  for (int k = -1; k >= walk.lo; --k) {
    walk_step(fields, walk.superior, -1.0, &p, &n);
    down.push_back(p), down_n.push_back(n);
  }
  walk.points.assign(down.rbegin(), down.rend());
  walk.normals.assign(down_n.rbegin(), down_n.rend());
  walk.points.insert(walk.points.end(), up.begin(), up.end());
  walk.normals.insert(walk.normals.end(), up_n.begin(), up_n.end());
  return walk;
}

// The target in the scene frame, on the scene's skin, with its patch normal.
SkinFrame target_on_skin(const FieldSampler& fields, const SearchTarget& target) {
  const Grid& grid = fields.grid();
  const Vec3d point = scene_of_world(grid, target.point_lps);
  Vec3d normal = unit(scene_of_world(grid, target.normal_lps) - scene_of_world(grid, Vec3d{}));
  if (!is_finite(point) || norm(normal) == 0.0)
    throw InputError("search path: the target needs a finite point and a normal");
  const FieldSample s = fields.sample_surf(point);
  if (!s.inside || std::fabs(s.value) > kMaxTargetOffSkinMm)
    throw InputError("search path: the target " + mm_text(target.point_lps) +
                     " (LPS) is not within 10 mm of this scene's skin (landmarks of another "
                     "scan?)");
  SkinFrame frame;
  frame.slide = patient_frame(grid).superior;
  frame.skin = onto_skin(fields, point, normal);
  const Vec3d patch = patch_normal(fields, frame.skin, frame.slide);
  frame.normal = norm(patch) > 0.0 ? patch : normal;
  frame.skin = onto_skin(fields, frame.skin, frame.normal);
  return frame;
}

// Rows of the trajectory, appended phase by phase on one clock.
struct Rows {
  const FieldSampler& fields;
  double pad_offset;
  double rate;
  Trajectory out;

  double now() const { return out.empty() ? 0.0 : out.back().t; }
  // The device pose with the pad `depth` below the skin of `frame` (negative: above it).
  Pose pose(const SkinFrame& frame, double depth) const {
    const Quat q = surface_orientation(frame.normal, frame.slide);
    const Vec3d centre =
        depth > 0.0 ? pad_centre_at_depth(fields, frame, depth) : frame.skin - depth * frame.normal;
    return pad_pose(centre, frame.normal, q, pad_offset);
  }
  // Rows over `duration`, after the last one; `at(f)` the pose at fraction f of the phase.
  template <class PoseAt>
  void phase(double duration, PoseAt at) {
    const double t0 = now();
    const std::size_t n = static_cast<std::size_t>(std::round(duration * rate));
    const std::size_t first = out.empty() ? 0 : 1;
    const std::size_t row0 = static_cast<std::size_t>(std::round(t0 * rate));
    for (std::size_t i = first; i <= n; ++i)
      out.push_back({static_cast<double>(row0 + i) / rate,
                     at(n == 0 ? 1.0 : static_cast<double>(i) / static_cast<double>(n))});
  }
};

Pose lerp_pose(const Pose& a, const Pose& b, double f) {
  Quat qb = b.orientation;
  const double d = a.orientation.w * qb.w + a.orientation.x * qb.x + a.orientation.y * qb.y +
                   a.orientation.z * qb.z;
  if (d < 0.0) qb = {-qb.w, -qb.x, -qb.y, -qb.z};
  const Quat q{(1.0 - f) * a.orientation.w + f * qb.w, (1.0 - f) * a.orientation.x + f * qb.x,
               (1.0 - f) * a.orientation.y + f * qb.y, (1.0 - f) * a.orientation.z + f * qb.z};
  return {(1.0 - f) * a.position + f * b.position, normalized(q)};
}

// One trial: approach at `start`, slide to `end`, hold, lift. Returns the mark's time.
double trial_rows(Rows& rows, const SkinWalk& walk, const SearchSpec& spec, double start,
                  double end) {
  const SkinFrame from = walk.at(start);
  rows.phase(spec.press_s, [&](double f) {
    return rows.pose(from, (1.0 - f) * -spec.approach_mm + f * spec.depth_mm);
  });
  rows.phase(std::fabs(end - start) / spec.speed_mm_s, [&](double f) {
    return rows.pose(walk.at((1.0 - f) * start + f * end), spec.depth_mm);
  });
  const SkinFrame to = walk.at(end);
  const double hold_start = rows.now();
  rows.phase(spec.hold_s, [&](double) { return rows.pose(to, spec.depth_mm); });
  // The mark at the hold's middle, on a row's time.
  const double mark = std::round((hold_start + 0.5 * spec.hold_s) * rows.rate) / rows.rate;
  rows.phase(spec.press_s, [&](double f) {
    return rows.pose(to, (1.0 - f) * spec.depth_mm - f * spec.approach_mm);
  });
  return mark;
}

}  // namespace

void validate(const SearchSpec& spec) {
  row_count(0.0, spec.rate_hz);
  check_finite(spec.start_mm, "--start");
  check_finite(spec.depth_mm, "--depth");
  check_non_negative(spec.approach_mm, "--approach");
  check_non_negative(spec.press_s, "--press-time");
  check_non_negative(spec.hold_s, "--hold");
  if (!(std::isfinite(spec.speed_mm_s) && spec.speed_mm_s > 0.0))
    throw UsageError("--speed must be a finite number > 0 (mm/s)");
  if (spec.misses_mm.empty() || spec.misses_mm.size() > kSearchMaxTrials)
    throw UsageError("--miss needs 1 to 100 values (one trial each)");
  for (double miss : spec.misses_mm) check_finite(miss, "each of --miss");
  const auto walk_ok = [](double mm) { return std::fabs(mm) <= kSearchMaxWalkMm; };
  if (!walk_ok(spec.start_mm) ||
      !std::all_of(spec.misses_mm.begin(), spec.misses_mm.end(), walk_ok))
    throw UsageError("--start and --miss must lie within 200 mm of the target");
}

SearchPath search_path(const FieldSampler& fields, const SearchTarget& target, double pad_offset,
                       const SearchSpec& spec) {
  validate(spec);
  SearchPath path;
  const SkinFrame goal = target_on_skin(fields, target);
  path.target_scene = goal.skin;
  const auto [lo, hi] = std::minmax_element(spec.misses_mm.begin(), spec.misses_mm.end());
  const SkinWalk walk = walk_skin(fields, goal.skin, goal.normal, std::min(*lo, spec.start_mm),
                                  std::max(*hi, spec.start_mm));
  Rows rows{fields, pad_offset, spec.rate_hz, {}};
  for (std::size_t k = 0; k < spec.misses_mm.size(); ++k) {
    const double miss = spec.misses_mm[k];
    if (k > 0) {
      // Through the air from above the last end to above this start.
      const Pose a = rows.out.back().pose;
      const Pose b = rows.pose(walk.at(spec.start_mm), -spec.approach_mm);
      rows.phase(norm(b.position - a.position) / spec.speed_mm_s,
                 [&](double f) { return lerp_pose(a, b, f); });
    }
    path.mark_times_s.push_back(trial_rows(rows, walk, spec, spec.start_mm, miss));
    path.end_points_scene.push_back(walk.at(miss).skin);
  }
  row_count(rows.now(), spec.rate_hz);  // refuses a path too long to write
  path.trajectory = std::move(rows.out);
  return path;
}

}  // namespace palp
