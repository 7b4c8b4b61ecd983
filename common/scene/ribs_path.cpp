// The ribs path over curved skin: the body axis, the skin frame along it, the pad at depth.
#include "scene/trajectory_gen.hpp"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <string>

#include "base/errors.hpp"
#include "scene/path_geometry.hpp"

namespace palp {

using namespace path_geometry;

namespace {

double grid_diagonal(const Grid& grid) {
  const Vec3 e = grid.extent_mm();
  return std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
}

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
