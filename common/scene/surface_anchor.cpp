// The skin search and the surface anchors: ray crossings, skin normals, approach sides, pad poses.
#include "scene/trajectory_gen.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>

#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "scene/path_geometry.hpp"

namespace palp {
namespace path_geometry {

// --- Skin search (declared and described in path_geometry.hpp) -------------------------------

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

Vec3d outward_normal(const FieldSampler& fields, const Vec3d& x) {
  const FieldSample s = fields.sample_surf(x);
  const double g = norm(s.grad);
  return s.inside && g >= kMinGradient ? s.grad * (-1.0 / g) : Vec3d{};
}

Vec3d patch_normal(const FieldSampler& fields, const Vec3d& skin, const Vec3d& slide) {
  const Vec3d n0 = outward_normal(fields, skin);
  if (norm(n0) == 0.0) return n0;
  const Vec3d t1 = unit(slide - dot(slide, n0) * n0);
  const Vec3d t2 = cross(n0, t1);
  // +-2.5 mm, or two voxels on a coarse grid (a 3 mm CT's terraces average out), sampled at
  // most a voxel apart
  const double half = patch_half_mm(fields.grid());
  const int steps = std::max(1, static_cast<int>(std::ceil(half / fields.grid().max_spacing())));
  Vec3d sum{};
  for (int a = -steps; a <= steps; ++a)
    for (int b = -steps; b <= steps; ++b)
      sum += outward_normal(fields, skin + (half * a / steps) * t1 + (half * b / steps) * t2);
  return unit(sum);
}

}  // namespace path_geometry

using namespace path_geometry;

namespace {

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
  // Rotation matrix with columns x, y, z -> quaternion, w >= 0.
  const Quat q = rotation_quaternion({x.x, y.x, z.x, x.y, y.y, z.y, x.z, y.z, z.z});
  return q.w < 0.0 ? Quat{-q.w, -q.x, -q.y, -q.z} : q;
}

Pose pad_pose(const Vec3d& pad_centre, const Vec3d& normal, const Quat& orientation,
              double pad_offset) {
  return {pad_centre + pad_offset * normal, orientation};
}

}  // namespace palp
