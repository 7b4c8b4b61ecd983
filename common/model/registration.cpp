// The device-to-scene registration: see registration.hpp.
#include "model/registration.hpp"

#include <cmath>
#include <cstdio>

#include "base/errors.hpp"

namespace palp {
namespace {

Vec3d times(const std::array<double, 9>& m, const Vec3d& v) {
  return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
          m[6] * v.x + m[7] * v.y + m[8] * v.z};
}

Vec3d times_transposed(const std::array<double, 9>& m, const Vec3d& v) {
  return {m[0] * v.x + m[3] * v.y + m[6] * v.z, m[1] * v.x + m[4] * v.y + m[7] * v.z,
          m[2] * v.x + m[5] * v.y + m[8] * v.z};
}

double determinant(const std::array<double, 9>& m) {
  return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
         m[2] * (m[3] * m[7] - m[4] * m[6]);
}

}  // namespace

bool Registration::is_identity() const {
  return rotation == std::array<double, 9>{1, 0, 0, 0, 1, 0, 0, 0, 1} && scale == 1.0 &&
         home == Vec3d{};
}

std::array<double, 9> rotation_from_axes(const PatientFrame& frame, std::string_view axes) {
  const auto bad = [&] {
    return UsageError("device axes '" + std::string(axes) +
                      "': expected three letters naming where the device's x, y, z point, one "
                      "of each pair L/R, P/A, S/I (e.g. IAR)");
  };
  if (axes.size() != 3) throw bad();
  std::array<double, 9> m{};
  int pair_used[3] = {0, 0, 0};
  for (int a = 0; a < 3; ++a) {
    Anatomy d{};
    if (!parse_anatomy(axes.substr(static_cast<std::size_t>(a), 1), &d)) throw bad();
    const int pair = d == Anatomy::Left || d == Anatomy::Right           ? 0
                     : d == Anatomy::Posterior || d == Anatomy::Anterior ? 1
                                                                         : 2;
    if (pair_used[pair]++) throw bad();
    const Vec3d c = frame.toward(d);
    m[static_cast<std::size_t>(a)] = c.x;
    m[static_cast<std::size_t>(3 + a)] = c.y;
    m[static_cast<std::size_t>(6 + a)] = c.z;
  }
  return m;
}

Vec3d point_to_scene(const Registration& r, const Vec3d& device_point) {
  return r.home + times(r.rotation, device_point) * r.scale;
}

Pose to_scene(const Registration& r, const Pose& device) {
  Pose p;
  p.position = point_to_scene(r, device.position);
  if (determinant(r.rotation) > 0) {
    p.orientation = multiply(rotation_quaternion(r.rotation), device.orientation);
  } else {
    // A mirrored registration: turn by the rotation part of -R; the mirror itself cannot turn a
    // tool (its contact points are symmetric enough for palp's tools).
    std::array<double, 9> proper{};
    for (std::size_t i = 0; i < 9; ++i) proper[i] = -r.rotation[i];
    p.orientation = multiply(rotation_quaternion(proper), device.orientation);
  }
  return p;
}

Vec3d scene_point_to_device(const Registration& r, const Vec3d& scene_point) {
  return times_transposed(r.rotation, scene_point - r.home) * (1.0 / r.scale);
}

Vec3d force_to_device(const Registration& r, const Vec3d& scene_force) {
  return times_transposed(r.rotation, scene_force);
}

Vec3d force_to_scene(const Registration& r, const Vec3d& device_force) {
  return times(r.rotation, device_force);
}

Vec3d torque_to_device(const Registration& r, const Vec3d& scene_torque) {
  const double sign = determinant(r.rotation) < 0 ? -1.0 : 1.0;
  return times_transposed(r.rotation, scene_torque) * (sign / r.scale);
}

Vec3d torque_to_scene(const Registration& r, const Vec3d& device_torque) {
  const double sign = determinant(r.rotation) < 0 ? -1.0 : 1.0;
  return times(r.rotation, device_torque) * (sign * r.scale);
}

std::string check_reach(const Registration& r, const Vec3d& skin, const Vec3d& normal,
                        const Vec3d& workspace_half_mm, double depth_mm) {
  const Vec3d target = skin - normal * depth_mm;
  const Vec3d d = scene_point_to_device(r, target);
  const bool inside = std::fabs(d.x) <= workspace_half_mm.x &&
                      std::fabs(d.y) <= workspace_half_mm.y &&
                      std::fabs(d.z) <= workspace_half_mm.z;
  if (inside) return {};
  char text[512];
  std::snprintf(text, sizeof text,
                "the device cannot reach %.0f mm below the skin at the home point: that needs "
                "(%.1f, %.1f, %.1f) mm in the device frame, its workspace is ±(%.0f, %.0f, %.0f) "
                "mm; lower --home-clearance, raise --device-scale or choose another --home",
                depth_mm, d.x, d.y, d.z, workspace_half_mm.x, workspace_half_mm.y,
                workspace_half_mm.z);
  return text;
}

}  // namespace palp
