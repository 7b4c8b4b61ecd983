// Trajectory generators (see trajectory_gen.hpp). Data flow of every path:
//   time t (row i / rate) -> phase (press, slide, hold, ...) -> lateral offset and depth
//   -> pad centre on the skin frame -> device pose (pad centre + pad_offset along the normal).
#include "scene/trajectory_gen.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>

#include "base/errors.hpp"
#include "base/patient_frame.hpp"

namespace palp {
namespace {

constexpr double kMaxRows = 1e8;          // refuse paths longer than this many rows
constexpr int kBisectionSteps = 60;       // skin search: interval / 2^60, far below 1 nm
constexpr int kDepthNewtonSteps = 6;      // pad-centre depth correction
constexpr double kNormalPatchHalf = 2.5;  // mm: the skin normal is averaged over +-2.5 mm
constexpr double kMinGradient = 1e-6;     // |grad D| below this: no direction

Vec3d unit(const Vec3d& v) {
  const double n = norm(v);
  return n > 0.0 ? v * (1.0 / n) : Vec3d{};
}

Vec3d axis_vector(int axis, double sign) {
  Vec3d v{};
  (axis == 0 ? v.x : axis == 1 ? v.y : v.z) = sign;
  return v;
}

double component(const Vec3d& v, int axis) {
  return axis == 0 ? v.x : axis == 1 ? v.y : v.z;
}

void set_component(Vec3d& v, int axis, double value) {
  (axis == 0 ? v.x : axis == 1 ? v.y : v.z) = value;
}

void check_finite(double value, const char* what) {
  if (!std::isfinite(value)) throw UsageError(std::string(what) + " must be a finite number");
}

void check_non_negative(double value, const char* what) {
  if (!(std::isfinite(value) && value >= 0.0))
    throw UsageError(std::string(what) + " must be a finite number >= 0");
}

// Rows of a path of `duration` at `rate`: round(duration * rate) + 1.
std::size_t row_count(double duration_s, double rate_hz) {
  if (!(std::isfinite(rate_hz) && rate_hz > 0.0))
    throw UsageError("--rate must be a finite number > 0 (Hz)");
  check_non_negative(duration_s, "the path's duration");
  const double rows = std::round(duration_s * rate_hz) + 1.0;
  if (!(rows <= kMaxRows)) throw UsageError("the path would have more than 1e8 rows");
  return static_cast<std::size_t>(rows);
}

double row_time(std::size_t row, double rate_hz) {
  return static_cast<double>(row) / rate_hz;
}

// Linear ramp from a to b as t goes from 0 to duration: a before it starts, b once it is over
// (and for duration 0 from t = 0 on).
double ramp(double a, double b, double t, double duration) {
  if (t < 0.0) return a;
  if (!(duration > 0.0) || t >= duration) return b;
  return a + (b - a) * (t / duration);
}

// A pose on the anchor's plane: lateral offsets (along slide, along x_tool) and depth.
struct FlatFrame {
  SurfaceAnchor anchor;
  Vec3d across{};  // x_tool = slide × normal
  Quat orientation{};
  double pad_offset = 0.0;

  Pose at(double along_slide, double along_across, double depth) const {
    const Vec3d centre =
        anchor.point + along_slide * anchor.slide + along_across * across - depth * anchor.normal;
    return pad_pose(centre, anchor.normal, orientation, pad_offset);
  }
};

FlatFrame flat_frame(const SurfaceAnchor& anchor, double pad_offset) {
  FlatFrame f;
  f.anchor.point = anchor.point;
  f.anchor.normal = unit(anchor.normal);
  if (!(norm(f.anchor.normal) > 0.5) || !is_finite(anchor.point))
    throw UsageError("surface anchor needs a finite point and a non-zero normal");
  f.orientation = surface_orientation(f.anchor.normal, anchor.slide);
  f.anchor.slide = rotate(f.orientation, Vec3d{0.0, 1.0, 0.0});
  f.across = rotate(f.orientation, Vec3d{1.0, 0.0, 0.0});
  f.pad_offset = pad_offset;
  return f;
}

// Distance covered after tau seconds of piecewise-constant speeds, segment_s each.
double piecewise_distance(const std::vector<double>& speeds, double segment_s, double tau) {
  double distance = 0.0;
  for (double speed : speeds) {
    const double dt = std::clamp(tau, 0.0, segment_s);
    distance += speed * dt;
    tau -= segment_s;
  }
  return distance;
}

// splitmix64: a deterministic stream for the jitter.
std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Uniform in [-1, 1) from (seed, row, axis).
double jitter_unit(std::uint64_t seed, std::size_t row, int axis) {
  const std::uint64_t h = splitmix64(
      seed ^ splitmix64(2 * static_cast<std::uint64_t>(row) + static_cast<std::uint64_t>(axis)));
  return static_cast<double>(h >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

// --- Skin search ------------------------------------------------------------------------------

struct RayHit {
  bool found = false;
  double lambda = 0.0;
};

// The first crossing of D_surf from (D > 0) to (D <= 0) going from `origin` along `dir`
// (inside_first) or from (D <= 0) to (D > 0) (!inside_first), within max_lambda; bisected.
RayHit find_crossing(const FieldSampler& fields, const Vec3d& origin, const Vec3d& dir,
                     double max_lambda, double step, bool inside_first) {
  auto body_at = [&](double lambda) {
    const FieldSample s = fields.sample_surf(origin + lambda * dir);
    return s.value > 0.0;
  };
  RayHit hit;
  double lo = 0.0;
  for (std::int64_t n = 1; lo < max_lambda; ++n) {
    double hi = std::min(static_cast<double>(n) * step, max_lambda);
    if (body_at(hi) != inside_first) {
      for (int i = 0; i < kBisectionSteps; ++i) {
        const double mid = 0.5 * (lo + hi);
        (body_at(mid) == inside_first ? lo : hi) = mid;
      }
      hit.found = true;
      hit.lambda = 0.5 * (lo + hi);
      return hit;
    }
    lo = hi;
  }
  return hit;
}

double grid_diagonal(const Grid& grid) {
  const Vec3 e = grid.extent_mm();
  return std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
}

// Outward unit normal -grad D / |grad D| at x, or zero without a direction.
Vec3d outward_normal(const FieldSampler& fields, const Vec3d& x) {
  const FieldSample s = fields.sample_surf(x);
  const double g = norm(s.grad);
  return s.inside && g >= kMinGradient ? s.grad * (-1.0 / g) : Vec3d{};
}

// The outward normal averaged over a patch of +-kNormalPatchHalf mm around the skin point.
Vec3d patch_normal(const FieldSampler& fields, const Vec3d& skin, const Vec3d& slide) {
  const Vec3d n0 = outward_normal(fields, skin);
  if (norm(n0) == 0.0) return n0;
  const Vec3d t1 = unit(slide - dot(slide, n0) * n0);
  const Vec3d t2 = cross(n0, t1);
  Vec3d sum{};
  for (double a : {-kNormalPatchHalf, 0.0, kNormalPatchHalf})
    for (double b : {-kNormalPatchHalf, 0.0, kNormalPatchHalf})
      sum += outward_normal(fields, skin + a * t1 + b * t2);
  return unit(sum);
}

struct SideRay {
  Vec3d origin;
  Vec3d dir;  // inward
  double length;
};

// The ray along the grid's centre line entering from the face at the `sign` end of `axis`.
SideRay side_ray(const Grid& grid, SignedAxis face) {
  const Vec3 e = grid.extent_mm();
  const Vec3d centre{e[0] / 2.0, e[1] / 2.0, e[2] / 2.0};
  SideRay ray;
  ray.origin = centre;
  set_component(ray.origin, face.axis, face.sign > 0 ? e[face.axis] : 0.0);
  ray.dir = axis_vector(face.axis, -static_cast<double>(face.sign));
  ray.length = e[face.axis];
  return ray;
}

// The grid face of an axis side (+x ... -z).
SignedAxis grid_face(ApproachSide side) {
  switch (side) {
    case ApproachSide::PlusX:
      return {0, 1};
    case ApproachSide::MinusX:
      return {0, -1};
    case ApproachSide::PlusY:
      return {1, 1};
    case ApproachSide::MinusY:
      return {1, -1};
    case ApproachSide::MinusZ:
      return {2, -1};
    default:
      return {2, 1};
  }
}

// The patient direction of a patient side; nullopt for Auto and the grid faces.
std::optional<Anatomy> patient_side(ApproachSide side) {
  switch (side) {
    case ApproachSide::Anterior:
      return Anatomy::Anterior;
    case ApproachSide::Posterior:
      return Anatomy::Posterior;
    case ApproachSide::Left:
      return Anatomy::Left;
    case ApproachSide::Right:
      return Anatomy::Right;
    case ApproachSide::Superior:
      return Anatomy::Superior;
    case ApproachSide::Inferior:
      return Anatomy::Inferior;
    default:
      return std::nullopt;
  }
}

// The anchor entering from `face`, sliding along `slide` projected onto the skin's tangent
// plane, if the ray starts in air and reaches skin.
bool anchor_from_face(const FieldSampler& fields, SignedAxis face, const Vec3d& slide,
                      SurfaceAnchor* anchor) {
  const SideRay ray = side_ray(fields.grid(), face);
  if (fields.sample_surf(ray.origin).value > 0.0) return false;  // starts inside the body
  const double step = 0.5 * fields.grid().min_spacing();
  const RayHit hit = find_crossing(fields, ray.origin, ray.dir, ray.length, step, false);
  if (!hit.found) return false;
  const Vec3d point = ray.origin + hit.lambda * ray.dir;
  const Vec3d normal = outward_normal(fields, point);
  if (dot(normal, ray.dir) > -0.5) return false;  // not facing the ray: an edge or a corner
  anchor->point = point;
  anchor->normal = normal;
  anchor->slide = unit(slide - dot(slide, normal) * normal);
  return true;
}

// A grid face: slide along +y on the z faces, +x on the others.
bool anchor_from_side(const FieldSampler& fields, ApproachSide side, SurfaceAnchor* anchor) {
  const SignedAxis face = grid_face(side);
  const Vec3d slide = face.axis == 2 ? Vec3d{0.0, 1.0, 0.0} : Vec3d{1.0, 0.0, 0.0};
  return anchor_from_face(fields, face, slide, anchor);
}

// A patient side: the grid face nearest to it; slide toward the patient's left, or superior
// when coming from the left or right. Both snapped to scene axes, so the anchor is the same
// anatomical point however the volume is stored.
bool anchor_from_patient_side(const FieldSampler& fields, Anatomy from, SurfaceAnchor* anchor) {
  const PatientFrame frame = patient_frame(fields.grid());
  const SignedAxis face = frame.nearest_axis(from);
  const bool lateral = from == Anatomy::Left || from == Anatomy::Right;
  const SignedAxis along = frame.nearest_axis(lateral ? Anatomy::Superior : Anatomy::Left);
  return anchor_from_face(fields, face, axis_vector(along.axis, along.sign), anchor);
}

// --- Body axis of the ribs path ---------------------------------------------------------------

// A scene-frame direction for an LPS direction: v = Dᵀ w (the direction matrix is orthonormal),
// snapped to the nearest scene axis.
Vec3d nearest_scene_axis(const Grid& grid, const Vec3d& lps, int* axis_out) {
  const auto& d = grid.world.direction;  // row-major, columns are the i, j, k directions
  const Vec3d w = lps;
  const Vec3d v{d[0] * w.x + d[3] * w.y + d[6] * w.z, d[1] * w.x + d[4] * w.y + d[7] * w.z,
                d[2] * w.x + d[5] * w.y + d[8] * w.z};
  int axis = 0;
  for (int a = 1; a < 3; ++a)
    if (std::fabs(component(v, a)) > std::fabs(component(v, axis))) axis = a;
  *axis_out = axis;
  return axis_vector(axis, component(v, axis) >= 0.0 ? 1.0 : -1.0);
}

// Centroid of the voxels with D_surf > 0 in the plane `axis` = `coordinate`.
Vec3d body_centroid_in_plane(const FieldSampler& fields, int axis, std::int64_t index) {
  const Grid& g = fields.grid();
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  Vec3d sum{};
  double count = 0.0;
  for (std::int64_t m = 0; m < g.dims[a2]; ++m) {
    for (std::int64_t l = 0; l < g.dims[a1]; ++l) {
      Vec3d x{};
      set_component(x, axis, static_cast<double>(index) * g.spacing[axis]);
      set_component(x, a1, static_cast<double>(l) * g.spacing[a1]);
      set_component(x, a2, static_cast<double>(m) * g.spacing[a2]);
      if (fields.sample_surf(x).value > 0.0) {
        sum += x;
        count += 1.0;
      }
    }
  }
  if (count == 0.0) throw InputError("ribs path: no body in the middle slice of the scene");
  return sum * (1.0 / count);
}

}  // namespace

ApproachSide parse_approach_side(std::string_view text) {
  if (text == "auto") return ApproachSide::Auto;
  if (text == "+x") return ApproachSide::PlusX;
  if (text == "-x") return ApproachSide::MinusX;
  if (text == "+y") return ApproachSide::PlusY;
  if (text == "-y") return ApproachSide::MinusY;
  if (text == "+z") return ApproachSide::PlusZ;
  if (text == "-z") return ApproachSide::MinusZ;
  if (text == "anterior") return ApproachSide::Anterior;
  if (text == "posterior") return ApproachSide::Posterior;
  if (text == "left") return ApproachSide::Left;
  if (text == "right") return ApproachSide::Right;
  if (text == "superior") return ApproachSide::Superior;
  if (text == "inferior") return ApproachSide::Inferior;
  throw UsageError("unknown side '" + std::string(text) +
                   "' (auto, anterior, posterior, left, right, superior, inferior, +x, -x, +y, "
                   "-y, +z, -z)");
}

const char* to_string(ApproachSide side) {
  switch (side) {
    case ApproachSide::Auto:
      return "auto";
    case ApproachSide::PlusX:
      return "+x";
    case ApproachSide::MinusX:
      return "-x";
    case ApproachSide::PlusY:
      return "+y";
    case ApproachSide::MinusY:
      return "-y";
    case ApproachSide::PlusZ:
      return "+z";
    case ApproachSide::MinusZ:
      return "-z";
    case ApproachSide::Anterior:
      return "anterior";
    case ApproachSide::Posterior:
      return "posterior";
    case ApproachSide::Left:
      return "left";
    case ApproachSide::Right:
      return "right";
    case ApproachSide::Superior:
      return "superior";
    case ApproachSide::Inferior:
      return "inferior";
  }
  return "auto";
}

SurfaceAnchor find_surface_anchor(const FieldSampler& fields, ApproachSide side) {
  SurfaceAnchor anchor;
  if (side == ApproachSide::Auto) {
    for (Anatomy a : {Anatomy::Anterior, Anatomy::Right, Anatomy::Left, Anatomy::Superior,
                      Anatomy::Inferior, Anatomy::Posterior}) {
      if (anchor_from_patient_side(fields, a, &anchor)) return anchor;
    }
    throw InputError("no skin reachable from outside along the grid's centre lines");
  }
  if (const std::optional<Anatomy> from = patient_side(side)) {
    if (anchor_from_patient_side(fields, *from, &anchor)) return anchor;
  } else if (anchor_from_side(fields, side, &anchor)) {
    return anchor;
  }
  throw InputError(std::string("no skin facing the ") + to_string(side) +
                   " side along the grid's centre line");
}

double pad_offset(const Tool& tool) {
  if (tool.points.empty()) throw UsageError("tool '" + tool.name + "' has no contact points");
  Vec3d centroid{};
  for (const Vec3d& p : tool.points) centroid += p;
  centroid *= 1.0 / static_cast<double>(tool.points.size());
  if (!(centroid.z < 0.0))
    throw UsageError("tool '" + tool.name + "': contact points do not lie below the device point");
  return -centroid.z;
}

Quat surface_orientation(const Vec3d& normal, const Vec3d& slide) {
  const Vec3d z = unit(normal);
  Vec3d y = slide - dot(slide, z) * z;
  if (norm(y) < 1e-9) {
    // Slide along the normal: take the scene axis least aligned with it.
    const int a = std::fabs(z.x) <= std::fabs(z.y) && std::fabs(z.x) <= std::fabs(z.z) ? 0
                  : std::fabs(z.y) <= std::fabs(z.z)                                   ? 1
                                                                                       : 2;
    const Vec3d e = axis_vector(a, 1.0);
    y = e - dot(e, z) * z;
  }
  y = unit(y);
  const Vec3d x = cross(y, z);
  // Rotation matrix with columns x, y, z -> quaternion (Shepperd's branches).
  const double m00 = x.x, m01 = y.x, m02 = z.x;
  const double m10 = x.y, m11 = y.y, m12 = z.y;
  const double m20 = x.z, m21 = y.z, m22 = z.z;
  const double trace = m00 + m11 + m22;
  Quat q;
  if (trace > 0.0) {
    const double s = 2.0 * std::sqrt(trace + 1.0);
    q = {0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s};
  } else if (m00 > m11 && m00 > m22) {
    const double s = 2.0 * std::sqrt(1.0 + m00 - m11 - m22);
    q = {(m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s};
  } else if (m11 > m22) {
    const double s = 2.0 * std::sqrt(1.0 + m11 - m00 - m22);
    q = {(m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s};
  } else {
    const double s = 2.0 * std::sqrt(1.0 + m22 - m00 - m11);
    q = {(m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s};
  }
  if (q.w < 0.0) q = {-q.w, -q.x, -q.y, -q.z};
  return normalized(q);
}

Pose pad_pose(const Vec3d& pad_centre, const Vec3d& normal, const Quat& orientation,
              double pad_offset) {
  return {pad_centre + pad_offset * normal, orientation};
}

void validate(const RibsSpec& spec) {
  row_count(0.0, spec.rate_hz);
  check_finite(spec.azimuth_deg, "--azimuth");
  check_finite(spec.depth_mm, "--depth");
  check_finite(spec.approach_mm, "--approach");
  check_non_negative(spec.press_s, "--press-time");
  if (!(spec.from >= 0.0 && spec.from <= 1.0 && spec.to >= 0.0 && spec.to <= 1.0))
    throw UsageError("--from and --to must lie in [0, 1] (fractions of the body axis)");
  if (!(std::isfinite(spec.speed_mm_s) && spec.speed_mm_s > 0.0))
    throw UsageError("--speed must be a finite number > 0 (mm/s)");
}

void validate(const SlideRampSpec& spec) {
  check_finite(spec.speed_mm_s, "--speed");
  check_finite(spec.depth_start_mm, "--depth-start");
  check_finite(spec.depth_end_mm, "--depth");
  row_count(spec.duration_s, spec.rate_hz);
}

void validate(const SlideSpeedSpec& spec) {
  check_finite(spec.depth_mm, "--depth");
  check_non_negative(spec.press_s, "--press-time");
  check_non_negative(spec.segment_s, "--segment");
  check_non_negative(spec.hold_s, "--hold");
  if (spec.speeds_mm_s.empty()) throw UsageError("--speeds needs at least one speed");
  for (double v : spec.speeds_mm_s) check_finite(v, "each of --speeds");
  row_count(
      spec.press_s + spec.segment_s * static_cast<double>(spec.speeds_mm_s.size()) + spec.hold_s,
      spec.rate_hz);
}

void validate(const PressHoldSpec& spec) {
  check_finite(spec.approach_mm, "--approach");
  check_finite(spec.depth_mm, "--depth");
  check_finite(spec.shift_mm, "--shift");
  check_non_negative(spec.press_s, "--press-time");
  check_non_negative(spec.shift_s, "--shift-time");
  check_non_negative(spec.hold_s, "--hold");
  check_non_negative(spec.jitter_mm, "--jitter");
  row_count(spec.press_s + spec.shift_s + spec.hold_s, spec.rate_hz);
}

Trajectory slide_ramp(const SurfaceAnchor& anchor, double pad_offset, const SlideRampSpec& spec) {
  validate(spec);
  const std::size_t rows = row_count(spec.duration_s, spec.rate_hz);
  const FlatFrame frame = flat_frame(anchor, pad_offset);
  const double travel = spec.speed_mm_s * spec.duration_s;
  Trajectory out(rows);
  for (std::size_t i = 0; i < rows; ++i) {
    // t -> lateral offset (constant speed, centred) and depth (linear ramp) -> pose.
    const double t = row_time(i, spec.rate_hz);
    const double along = -0.5 * travel + spec.speed_mm_s * t;
    const double depth = ramp(spec.depth_start_mm, spec.depth_end_mm, t, spec.duration_s);
    out[i] = {t, frame.at(along, 0.0, depth)};
  }
  return out;
}

Trajectory slide_speed(const SurfaceAnchor& anchor, double pad_offset, const SlideSpeedSpec& spec) {
  validate(spec);
  const double slide_s = spec.segment_s * static_cast<double>(spec.speeds_mm_s.size());
  const double duration = spec.press_s + slide_s + spec.hold_s;
  const std::size_t rows = row_count(duration, spec.rate_hz);
  const FlatFrame frame = flat_frame(anchor, pad_offset);
  const double travel = piecewise_distance(spec.speeds_mm_s, spec.segment_s, slide_s);
  Trajectory out(rows);
  for (std::size_t i = 0; i < rows; ++i) {
    // t -> press at rest, slide at the segment's speed, hold at rest -> pose.
    const double t = row_time(i, spec.rate_hz);
    const double depth = ramp(0.0, spec.depth_mm, t, spec.press_s);
    const double moved = piecewise_distance(spec.speeds_mm_s, spec.segment_s, t - spec.press_s);
    out[i] = {t, frame.at(-0.5 * travel + moved, 0.0, depth)};
  }
  return out;
}

Trajectory press_hold(const SurfaceAnchor& anchor, double pad_offset, const PressHoldSpec& spec) {
  validate(spec);
  const double hold_start = spec.press_s + spec.shift_s;
  const std::size_t rows = row_count(hold_start + spec.hold_s, spec.rate_hz);
  const FlatFrame frame = flat_frame(anchor, pad_offset);
  Trajectory out(rows);
  for (std::size_t i = 0; i < rows; ++i) {
    // t -> press (depth ramp), shift (lateral ramp), hold (+ jitter on both tangents) -> pose.
    const double t = row_time(i, spec.rate_hz);
    const double depth = ramp(-spec.approach_mm, spec.depth_mm, t, spec.press_s);
    double along = ramp(0.0, spec.shift_mm, t - spec.press_s, spec.shift_s);
    double across = 0.0;
    if (t > hold_start && spec.jitter_mm > 0.0) {
      along += spec.jitter_mm * jitter_unit(spec.seed, i, 0);
      across += spec.jitter_mm * jitter_unit(spec.seed, i, 1);
    }
    out[i] = {t, frame.at(along, across, depth)};
  }
  return out;
}

BodyAxis ribs_body_axis(const FieldSampler& fields, const RibsSpec& spec) {
  validate(spec);
  const Grid& g = fields.grid();
  BodyAxis axis;
  int lateral_axis = 0, anterior_axis = 0;
  axis.superior = nearest_scene_axis(g, {0.0, 0.0, 1.0}, &axis.axis);
  const double lateral_sign = spec.side == BodySide::Right ? -1.0 : 1.0;  // LPS: +x is left
  const Vec3d lateral = nearest_scene_axis(g, {lateral_sign, 0.0, 0.0}, &lateral_axis);
  const Vec3d anterior = nearest_scene_axis(g, {0.0, -1.0, 0.0}, &anterior_axis);
  if (lateral_axis == axis.axis || anterior_axis == axis.axis || lateral_axis == anterior_axis)
    throw InputError("ribs path: the image orientation does not separate the body axes");
  const double azimuth = spec.azimuth_deg * std::numbers::pi / 180.0;
  axis.ray = unit(std::cos(azimuth) * lateral + std::sin(azimuth) * anterior);
  axis.extent = g.extent_mm()[axis.axis];
  axis.centre = body_centroid_in_plane(fields, axis.axis, g.dims[axis.axis] / 2);
  return axis;
}

SkinFrame ribs_skin_frame(const FieldSampler& fields, const BodyAxis& axis, double along) {
  // Fraction along the body axis (0 = inferior end) -> point on the axis -> skin along the ray.
  const double from_inferior = along * axis.extent;
  Vec3d base = axis.centre;
  set_component(
      base, axis.axis,
      component(axis.superior, axis.axis) > 0.0 ? from_inferior : axis.extent - from_inferior);
  const double position = component(base, axis.axis);
  char where[64];
  std::snprintf(where, sizeof where, " at %.4g mm along the body axis", position);
  if (!(fields.sample_surf(base).value > 0.0))
    throw InputError(std::string("ribs path: the body axis lies outside the body") + where);
  const Grid& g = fields.grid();
  const RayHit hit =
      find_crossing(fields, base, axis.ray, grid_diagonal(g), 0.5 * g.min_spacing(), true);
  SkinFrame frame;
  frame.skin = base + hit.lambda * axis.ray;
  frame.slide = axis.superior;
  if (!hit.found || !fields.sample_surf(frame.skin).inside)
    throw InputError(std::string("ribs path: the body reaches the grid's edge") + where);
  frame.normal = patch_normal(fields, frame.skin, frame.slide);
  if (norm(frame.normal) == 0.0) throw InputError(std::string("ribs path: no skin normal") + where);
  return frame;
}

Vec3d pad_centre_at_depth(const FieldSampler& fields, const SkinFrame& frame, double depth_mm) {
  Vec3d centre = frame.skin - depth_mm * frame.normal;
  for (int i = 0; i < kDepthNewtonSteps; ++i) {
    // D decreases by about 1 mm per mm along the outward normal.
    const FieldSample s = fields.sample_surf(centre);
    if (!s.inside) break;
    const double error = s.value - depth_mm;
    if (std::fabs(error) < 1e-9) break;
    centre += error * frame.normal;
  }
  return centre;
}

Trajectory ribs_slide(const FieldSampler& fields, double pad_offset, const RibsSpec& spec) {
  const BodyAxis axis = ribs_body_axis(fields, spec);
  const double slide_mm = std::fabs(spec.to - spec.from) * axis.extent;
  const double slide_s = slide_mm / spec.speed_mm_s;
  const double duration = 2.0 * spec.press_s + slide_s;
  const std::size_t rows = row_count(duration, spec.rate_hz);
  Trajectory out(rows);
  double frame_along = -1.0;
  SkinFrame frame;
  for (std::size_t i = 0; i < rows; ++i) {
    // t -> (position along the body axis, depth): press at `from`, slide, lift at `to`.
    const double t = row_time(i, spec.rate_hz);
    const double t_slide = t - spec.press_s;
    const double t_lift = t_slide - slide_s;
    const double along = ramp(spec.from, spec.to, t_slide, slide_s);
    const double depth = t_slide < 0.0 ? ramp(-spec.approach_mm, spec.depth_mm, t, spec.press_s)
                         : t_lift > 0.0
                             ? ramp(spec.depth_mm, -spec.approach_mm, t_lift, spec.press_s)
                             : spec.depth_mm;
    // (along, depth) -> skin frame on the ray -> pad centre at depth -> device pose.
    if (along != frame_along) {
      frame = ribs_skin_frame(fields, axis, along);
      frame_along = along;
    }
    const Quat q = surface_orientation(frame.normal, frame.slide);
    out[i] = {t, pad_pose(pad_centre_at_depth(fields, frame, depth), frame.normal, q, pad_offset)};
  }
  return out;
}

}  // namespace palp
