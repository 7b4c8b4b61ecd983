// Small 3-vector and unit-quaternion arithmetic for the force loop: everything inline, no
// allocation, no dependencies. Vec3d is the force model's vector (mm, N, N·mm); palp::Vec3
// (std::array, volume.hpp) stays the grid's type and converts with to_vec3d / to_vec3.
#pragma once

#include <array>
#include <cmath>

#include "base/volume.hpp"

namespace palp {

struct Vec3d {
  double x = 0.0, y = 0.0, z = 0.0;

  constexpr Vec3d& operator+=(const Vec3d& b) {
    x += b.x, y += b.y, z += b.z;
    return *this;
  }
  constexpr Vec3d& operator-=(const Vec3d& b) {
    x -= b.x, y -= b.y, z -= b.z;
    return *this;
  }
  constexpr Vec3d& operator*=(double s) {
    x *= s, y *= s, z *= s;
    return *this;
  }
  constexpr bool operator==(const Vec3d&) const = default;
};

constexpr Vec3d operator+(Vec3d a, const Vec3d& b) {
  return a += b;
}
constexpr Vec3d operator-(Vec3d a, const Vec3d& b) {
  return a -= b;
}
constexpr Vec3d operator-(const Vec3d& a) {
  return {-a.x, -a.y, -a.z};
}
constexpr Vec3d operator*(Vec3d a, double s) {
  return a *= s;
}
constexpr Vec3d operator*(double s, Vec3d a) {
  return a *= s;
}

constexpr double dot(const Vec3d& a, const Vec3d& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
constexpr Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double norm(const Vec3d& a) {
  return std::sqrt(dot(a, a));
}
inline bool is_finite(const Vec3d& a) {
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}

constexpr Vec3d to_vec3d(const Vec3& a) {
  return {a[0], a[1], a[2]};
}
constexpr Vec3 to_vec3(const Vec3d& a) {
  return {a.x, a.y, a.z};
}

// Rotation quaternion, scalar first (w, x, y, z) as in the trajectory CSV.
struct Quat {
  double w = 1.0, x = 0.0, y = 0.0, z = 0.0;
  constexpr bool operator==(const Quat&) const = default;
};

inline double norm(const Quat& q) {
  return std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
}

// q / |q|; a zero or non-finite quaternion comes back with NaN components (the caller checks).
inline Quat normalized(const Quat& q) {
  const double n = norm(q);
  const double inv = n > 0.0 ? 1.0 / n : std::nan("");
  return {q.w * inv, q.x * inv, q.y * inv, q.z * inv};
}

// Rotates v by the unit quaternion q: v' = v + 2w (u × v) + 2 u × (u × v), u = (x, y, z).
constexpr Vec3d rotate(const Quat& q, const Vec3d& v) {
  const Vec3d u{q.x, q.y, q.z};
  const Vec3d t = 2.0 * cross(u, v);
  return v + q.w * t + cross(u, t);
}

// Unit quaternion for a rotation of `angle` radians about the unit axis `axis`.
inline Quat axis_angle(const Vec3d& axis, double angle) {
  const double s = std::sin(0.5 * angle);
  return {std::cos(0.5 * angle), axis.x * s, axis.y * s, axis.z * s};
}

// Quaternion product a * b (apply b first, then a).
constexpr Quat multiply(const Quat& a, const Quat& b) {
  return {
      a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z, a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
      a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x, a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}

// The unit quaternion of a proper rotation matrix (row-major; Shepperd's branches), normalized.
inline Quat rotation_quaternion(const std::array<double, 9>& m) {
  const double trace = m[0] + m[4] + m[8];
  Quat q;
  if (trace > 0.0) {
    const double s = 2.0 * std::sqrt(trace + 1.0);
    q = {0.25 * s, (m[7] - m[5]) / s, (m[2] - m[6]) / s, (m[3] - m[1]) / s};
  } else if (m[0] > m[4] && m[0] > m[8]) {
    const double s = 2.0 * std::sqrt(1.0 + m[0] - m[4] - m[8]);
    q = {(m[7] - m[5]) / s, 0.25 * s, (m[1] + m[3]) / s, (m[2] + m[6]) / s};
  } else if (m[4] > m[8]) {
    const double s = 2.0 * std::sqrt(1.0 + m[4] - m[0] - m[8]);
    q = {(m[2] - m[6]) / s, (m[1] + m[3]) / s, 0.25 * s, (m[5] + m[7]) / s};
  } else {
    const double s = 2.0 * std::sqrt(1.0 + m[8] - m[0] - m[4]);
    q = {(m[3] - m[1]) / s, (m[2] + m[6]) / s, (m[5] + m[7]) / s, 0.25 * s};
  }
  return normalized(q);
}

// A rigid pose: where the device point is and how the tool is turned.
struct Pose {
  Vec3d position{};    // mm, scene frame: the device point
  Quat orientation{};  // tool frame -> scene frame
};

}  // namespace palp
