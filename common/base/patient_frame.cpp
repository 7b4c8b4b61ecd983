// Patient directions in the scene frame: see patient_frame.hpp.
#include "base/patient_frame.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

namespace palp {
namespace {

double component(const Vec3d& v, int axis) {
  return axis == 0 ? v.x : axis == 1 ? v.y : v.z;
}

Vec3d unit_or_zero(const Vec3d& v) {
  const double n = norm(v);
  return n > 0.0 ? v * (1.0 / n) : Vec3d{};
}

bool is_rotation(const std::array<double, 9>& d) {
  for (double x : d)
    if (!std::isfinite(x)) return false;
  const Vec3d c0{d[0], d[3], d[6]}, c1{d[1], d[4], d[7]}, c2{d[2], d[5], d[8]};
  const double tol = 1e-3;
  if (std::fabs(norm(c0) - 1.0) > tol || std::fabs(norm(c1) - 1.0) > tol ||
      std::fabs(norm(c2) - 1.0) > tol)
    return false;
  if (std::fabs(dot(c0, c1)) > tol || std::fabs(dot(c0, c2)) > tol || std::fabs(dot(c1, c2)) > tol)
    return false;
  return std::fabs(std::fabs(dot(cross(c0, c1), c2)) - 1.0) <= tol;  // mirrored frames allowed
}

}  // namespace

const char* to_string(Anatomy direction) {
  switch (direction) {
    case Anatomy::Left:
      return "left";
    case Anatomy::Right:
      return "right";
    case Anatomy::Posterior:
      return "posterior";
    case Anatomy::Anterior:
      return "anterior";
    case Anatomy::Superior:
      return "superior";
    case Anatomy::Inferior:
      return "inferior";
  }
  return "?";
}

char letter(Anatomy direction) {
  return static_cast<char>(std::toupper(static_cast<unsigned char>(to_string(direction)[0])));
}

std::string to_string(SignedAxis axis) {
  return std::string(axis.sign > 0 ? "+" : "-") + "xyz"[axis.axis];
}

Anatomy opposite(Anatomy direction) {
  switch (direction) {
    case Anatomy::Left:
      return Anatomy::Right;
    case Anatomy::Right:
      return Anatomy::Left;
    case Anatomy::Posterior:
      return Anatomy::Anterior;
    case Anatomy::Anterior:
      return Anatomy::Posterior;
    case Anatomy::Superior:
      return Anatomy::Inferior;
    case Anatomy::Inferior:
      return Anatomy::Superior;
  }
  return direction;
}

Vec3d PatientFrame::toward(Anatomy direction) const {
  switch (direction) {
    case Anatomy::Left:
      return left;
    case Anatomy::Right:
      return -left;
    case Anatomy::Posterior:
      return posterior;
    case Anatomy::Anterior:
      return -posterior;
    case Anatomy::Superior:
      return superior;
    case Anatomy::Inferior:
      return -superior;
  }
  return {};
}

SignedAxis PatientFrame::nearest_axis(Anatomy direction) const {
  const Vec3d v = toward(direction);
  SignedAxis best;
  for (int a = 1; a < 3; ++a)
    if (std::fabs(component(v, a)) > std::fabs(component(v, best.axis))) best.axis = a;
  best.sign = component(v, best.axis) >= 0.0 ? 1 : -1;
  return best;
}

Anatomy PatientFrame::axis_direction(int axis) const {
  // The index axis in patient terms is column `axis` of D: (left, posterior, superior)[axis].
  const double l = component(left, axis), p = component(posterior, axis),
               s = component(superior, axis);
  if (std::fabs(l) >= std::fabs(p) && std::fabs(l) >= std::fabs(s))
    return l >= 0.0 ? Anatomy::Left : Anatomy::Right;
  if (std::fabs(p) >= std::fabs(s)) return p >= 0.0 ? Anatomy::Posterior : Anatomy::Anterior;
  return s >= 0.0 ? Anatomy::Superior : Anatomy::Inferior;
}

std::string PatientFrame::orientation_code() const {
  std::string code;
  for (int a = 0; a < 3; ++a) code += letter(axis_direction(a));
  return code;
}

double PatientFrame::obliquity_deg() const {
  double worst = 0.0;
  for (int a = 0; a < 3; ++a) {
    const double largest =
        std::max({std::fabs(component(left, a)), std::fabs(component(posterior, a)),
                  std::fabs(component(superior, a))});
    const Vec3d column{component(left, a), component(posterior, a), component(superior, a)};
    const double cosine = std::min(1.0, largest / norm(column));
    worst = std::max(worst, std::acos(cosine) * 180.0 / 3.14159265358979323846);
  }
  return worst;
}

PatientFrame patient_frame(const WorldPlacement& world) {
  const auto& d = world.direction;  // row-major: row r holds LPS component r of each column
  PatientFrame f;
  if (!is_rotation(d)) return f;
  f.left = unit_or_zero(Vec3d{d[0], d[1], d[2]});
  f.posterior = unit_or_zero(Vec3d{d[3], d[4], d[5]});
  f.superior = unit_or_zero(Vec3d{d[6], d[7], d[8]});
  return f;
}

PatientFrame patient_frame(const Grid& grid) {
  return patient_frame(grid.world);
}

namespace {

// Column a of the row-major direction: where index axis a points in the patient.
Vec3d direction_column(const Grid& grid, int a) {
  const auto& d = grid.world.direction;
  return {d[static_cast<std::size_t>(a)], d[static_cast<std::size_t>(3 + a)],
          d[static_cast<std::size_t>(6 + a)]};
}

}  // namespace

Vec3d world_of_scene(const Grid& grid, const Vec3d& scene_mm) {
  Vec3d w = to_vec3d(grid.world.origin);
  for (int a = 0; a < 3; ++a) w += direction_column(grid, a) * component(scene_mm, a);
  return w;
}

Vec3d scene_of_world(const Grid& grid, const Vec3d& world_mm) {
  const Vec3d r = world_mm - to_vec3d(grid.world.origin);
  return {dot(direction_column(grid, 0), r), dot(direction_column(grid, 1), r),
          dot(direction_column(grid, 2), r)};
}

bool parse_anatomy(std::string_view text, Anatomy* out) {
  for (Anatomy a : {Anatomy::Left, Anatomy::Right, Anatomy::Posterior, Anatomy::Anterior,
                    Anatomy::Superior, Anatomy::Inferior}) {
    if (text == to_string(a) || (text.size() == 1 && text[0] == letter(a))) {
      *out = a;
      return true;
    }
  }
  return false;
}

}  // namespace palp
