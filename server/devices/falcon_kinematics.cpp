// Falcon kinematics (falcon_kinematics.hpp). Derivation, per leg i in its own frame
// q = (u, v, w) = R(phi_i) p + (-r, -s, 0):
//   the shin parallelogram fixes t3 from v alone:  v = b cos t3 - f  ->  t3 = acos((v + f) / b);
//   the knee circle then ties t1 to (u, w):  (u + c - a cos t1)^2 + (w - a sin t1)^2 = L^2 with
//   L = d + e + b sin t3. With T = tan(t1 / 2) this is l2 T^2 + l1 T + l0 = 0,
//   l2 = (u + c + a)^2 + w^2 - L^2, l1 = -4 a w, l0 = (u + c - a)^2 + w^2 - L^2, and the Falcon's
//   assembly is the root T = (-l1 - sqrt(l1^2 - 4 l0 l2)) / (2 l2).
// Jacobian: implicit differentiation of G(t1, q) = (X)^2 + (Z)^2 - L(v)^2 = 0 with
// X = u + c - a cos t1, Z = w - a sin t1, dL/dv = -cot t3:
//   dt1/dq = -(2X, 2 L cot t3, 2Z) / (2a (X sin t1 - Z cos t1)),  dt1/dp = dt1/dq R(phi_i).
#include "devices/falcon_kinematics.hpp"

#include <algorithm>
#include <cmath>

namespace palp::falcon {
namespace {

struct LegFrame {
  double cos_phi, sin_phi;
};

LegFrame leg(int i) {
  const double phi = kPhi[static_cast<std::size_t>(i)];
  return {std::cos(phi), std::sin(phi)};
}

Vec3d to_leg(const LegFrame& l, const Vec3d& p) {
  return {l.cos_phi * p.x + l.sin_phi * p.y - kR, -l.sin_phi * p.x + l.cos_phi * p.y - kS, p.z};
}

double component(const Vec3d& v, int i) {
  return i == 0 ? v.x : (i == 1 ? v.y : v.z);
}
void set_component(Vec3d& v, int i, double value) {
  (i == 0 ? v.x : (i == 1 ? v.y : v.z)) = value;
}

// t1 and the pieces the Jacobian needs, for one leg; false outside the reach.
struct LegSolution {
  double t1 = 0, t3 = 0, L = 0, X = 0, Z = 0;
};
bool solve_leg(const Vec3d& q, LegSolution& s) {
  const double cos_t3 = (q.y + kF) / kB;
  if (!(std::abs(cos_t3) < 1.0)) return false;
  s.t3 = std::acos(cos_t3);
  s.L = kD + kE + kB * std::sin(s.t3);
  const double x0 = q.x + kC, w = q.z;
  const double l2 = (x0 + kA) * (x0 + kA) + w * w - s.L * s.L;
  const double l1 = -4.0 * kA * w;
  const double l0 = (x0 - kA) * (x0 - kA) + w * w - s.L * s.L;
  const double disc = l1 * l1 - 4.0 * l0 * l2;
  if (!(disc >= 0.0) || l2 == 0.0) return false;
  const double T = (-l1 - std::sqrt(disc)) / (2.0 * l2);
  s.t1 = 2.0 * std::atan(T);
  s.X = x0 - kA * std::cos(s.t1);
  s.Z = w - kA * std::sin(s.t1);
  return std::isfinite(s.t1);
}

}  // namespace

Vec3d multiply(const Mat3& a, const Vec3d& v) {
  return {a(0, 0) * v.x + a(0, 1) * v.y + a(0, 2) * v.z,
          a(1, 0) * v.x + a(1, 1) * v.y + a(1, 2) * v.z,
          a(2, 0) * v.x + a(2, 1) * v.y + a(2, 2) * v.z};
}

Vec3d multiply_transposed(const Mat3& a, const Vec3d& v) {
  return {a(0, 0) * v.x + a(1, 0) * v.y + a(2, 0) * v.z,
          a(0, 1) * v.x + a(1, 1) * v.y + a(2, 1) * v.z,
          a(0, 2) * v.x + a(1, 2) * v.y + a(2, 2) * v.z};
}

bool invert(const Mat3& a, Mat3& out) {
  const double c00 = a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1);
  const double c01 = a(1, 2) * a(2, 0) - a(1, 0) * a(2, 2);
  const double c02 = a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0);
  const double det = a(0, 0) * c00 + a(0, 1) * c01 + a(0, 2) * c02;
  double scale = 0.0;
  for (const double v : a.m) scale = std::max(scale, std::abs(v));
  if (!std::isfinite(det) || std::abs(det) <= 1e-12 * scale * scale * scale) return false;
  const double inv = 1.0 / det;
  out(0, 0) = c00 * inv;
  out(1, 0) = c01 * inv;
  out(2, 0) = c02 * inv;
  out(0, 1) = (a(0, 2) * a(2, 1) - a(0, 1) * a(2, 2)) * inv;
  out(1, 1) = (a(0, 0) * a(2, 2) - a(0, 2) * a(2, 0)) * inv;
  out(2, 1) = (a(0, 1) * a(2, 0) - a(0, 0) * a(2, 1)) * inv;
  out(0, 2) = (a(0, 1) * a(1, 2) - a(0, 2) * a(1, 1)) * inv;
  out(1, 2) = (a(0, 2) * a(1, 0) - a(0, 0) * a(1, 2)) * inv;
  out(2, 2) = (a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0)) * inv;
  return true;
}

// Degrees per count: the shaft's arc per quadrature count over the arm capstan's circumference.
double joint_angle(std::int32_t encoder) {
  const double deg_per_count =
      (kShaftDiameter * kPi / (4.0 * kWheelSlots)) / (kPi * kSmallArmDiameter / 360.0);
  return (static_cast<double>(encoder) * deg_per_count + kThetaOffsetDeg) * kPi / 180.0;
}

double encoder_counts(double joint_angle_rad) {
  const double deg_per_count =
      (kShaftDiameter * kPi / (4.0 * kWheelSlots)) / (kPi * kSmallArmDiameter / 360.0);
  return (joint_angle_rad * 180.0 / kPi - kThetaOffsetDeg) / deg_per_count;
}

bool inverse(const Vec3d& p, Vec3d& angles) {
  for (int i = 0; i < 3; ++i) {
    LegSolution s;
    if (!solve_leg(to_leg(leg(i), p), s)) return false;
    set_component(angles, i, s.t1);
  }
  return true;
}

bool jacobian(const Vec3d& p, Mat3& J) {
  for (int i = 0; i < 3; ++i) {
    const LegFrame l = leg(i);
    LegSolution s;
    if (!solve_leg(to_leg(l, p), s)) return false;
    const double dG_dt1 = kA * (s.X * std::sin(s.t1) - s.Z * std::cos(s.t1));
    if (!(std::abs(dG_dt1) > 1e-12)) return false;
    // dt1/dq (the factor 2 cancels)
    const double du = -s.X / dG_dt1;
    const double dv = -(s.L * std::cos(s.t3) / std::sin(s.t3)) / dG_dt1;
    const double dw = -s.Z / dG_dt1;
    // q = R p + o, R = [[c, s, 0], [-s, c, 0], [0, 0, 1]]
    J(i, 0) = du * l.cos_phi - dv * l.sin_phi;
    J(i, 1) = du * l.sin_phi + dv * l.cos_phi;
    J(i, 2) = dw;
  }
  return true;
}

bool forward(const Vec3d& angles, const Vec3d& guess, Vec3d& out) {
  Vec3d p = guess;
  for (int step = 0; step < 30; ++step) {
    Vec3d t;
    Mat3 J, Jinv;
    if (!inverse(p, t) || !jacobian(p, J) || !invert(J, Jinv)) {
      if (step == 0 && !(guess == kWorkspaceCentre)) {
        p = kWorkspaceCentre;  // a bad guess (e.g. after a jump): start again from the centre
        continue;
      }
      return false;
    }
    const Vec3d r = t - angles;
    const double err = std::max({std::abs(r.x), std::abs(r.y), std::abs(r.z)});
    if (err < 1e-9) {
      out = p;
      return true;
    }
    Vec3d dp = multiply(Jinv, r);
    // a step longer than 20 mm is cut (keeps Newton inside the reach far from the solution)
    const double len = norm(dp);
    if (len > 20.0) dp = dp * (20.0 / len);
    p -= dp;
  }
  return false;
}

bool joint_torques(const Vec3d& p, const Vec3d& force, Vec3d& torque) {
  Mat3 J, Jinv;
  if (!jacobian(p, J) || !invert(J, Jinv)) return false;
  torque = multiply_transposed(Jinv, force);  // tau = J^-T F
  return is_finite(torque);
}

bool end_effector_force(const Vec3d& p, const Vec3d& torque, Vec3d& force) {
  Mat3 J;
  if (!jacobian(p, J)) return false;
  force = multiply_transposed(J, torque);  // F = J^T tau
  return is_finite(force);
}

Efforts efforts_for_force(const Vec3d& p, const Vec3d& force, int max_effort) {
  Efforts e;
  max_effort = std::clamp(max_effort, 0, kMaxEffort);
  Vec3d tau;
  if (!is_finite(force) || !is_finite(p) || !joint_torques(p, force, tau)) return e;
  Vec3d raw = tau * -kEffortPerNmm;
  const double largest = std::max({std::abs(raw.x), std::abs(raw.y), std::abs(raw.z)});
  if (largest > static_cast<double>(max_effort)) {
    raw = raw * (static_cast<double>(max_effort) / largest);
    e.clamped = true;
  }
  for (int i = 0; i < 3; ++i) {
    const double v =
        std::clamp(std::round(component(raw, i)), -double(max_effort), double(max_effort));
    e.value[static_cast<std::size_t>(i)] = static_cast<std::int16_t>(v);
  }
  return e;
}

Vec3d torques_from_efforts(const std::array<std::int16_t, 3>& efforts) {
  return Vec3d{double(efforts[0]), double(efforts[1]), double(efforts[2])} * (-1.0 / kEffortPerNmm);
}

}  // namespace palp::falcon
