// An independent transcription, for tests only, of the Novint Falcon's published constants and of
// libnifalcon's Stamper kinematics (Alastair Barrow's, after R. E. Stamper 1997): palp's own code
// in test support, written from the equations in libnifalcon, not from palp's
// server/devices/falcon_kinematics or server/usb/falcon_protocol (neither is included here, nor by
// the Falcon emulator that uses this file).
//
// Source: github.com/libnifalcon/libnifalcon, commit f7c727aa24403ea10dc1507d7d396eeb7d55564a
// (BSD-3). Every constant and equation names its file and line there. Abbreviations:
//   GEO  include/falcon/core/FalconGeometry.h
//   KIN  include/falcon/core/FalconKinematic.h
//   STA  src/kinematic/FalconKinematicStamper.cpp
//   FW   include/falcon/core/FalconFirmware.h
//   SDK  src/firmware/FalconFirmwareNovintSDK.cpp
//   GRIP include/falcon/grip/FalconGripFourButton.h
//   COMM src/comm/FalconCommLibUSB.cpp      CORE include/falcon/core/FalconComm.h
//   LOAD src/core/FalconFirmware.cpp
//   OLD  boneyard/ouellet_kinematics/FalconKinematicStamper.cpp (the kinematics libnifalcon
//        shipped before Barrow's)
// Units as there: metres, radians (degrees where noted), newtons, newton metres.
//
// One deliberate difference, switchable: STA:113/120/127 write the Jacobian's z column as
// sin(theta2)^2 / den. Differentiating STA's own inverse kinematics (u = a cos t1 - c + L cos t2,
// v = b cos t3 - f, w = a sin t1 + L sin t2, L = d + e + b sin t3; STA:56-93) gives
// sin(theta2) sin(theta3) / den, the form of the x and y columns next to it (STA:111-112), and
// finite differences of STA's inverse kinematics agree with that form, not with the printed one
// (tests/common/model/falcon_reference_test.cpp). JzForm::Printed keeps STA as printed, for that
// test; everything else uses JzForm::Derived.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>

namespace palp::falconref {

// ---- Geometry (GEO) ----
inline constexpr double kPi = 3.14159265;     // GEO:34, truncated there; kept as there
inline constexpr double kWheelSlots = 320;    // GEO:20
inline constexpr double kShaftD = 0.01425;    // GEO:21, m
inline constexpr double kSmallArmD = 0.110;   // GEO:22, m
inline constexpr double kThetaOffset = 35;    // GEO:23, degrees at encoder 0
inline constexpr double a = 0.060;            // GEO:25
inline constexpr double b = 0.1025;           // GEO:26
inline constexpr double c = 0.01443;          // GEO:27
inline constexpr double d = 0.01125;          // GEO:28
inline constexpr double e = d;                // GEO:29
inline constexpr double f = -0.025;           // GEO:30
inline constexpr double r = 0.0400;           // GEO:31
inline constexpr double s = -0.02309;         // GEO:32
inline constexpr double kLegTilt = kPi / 12;  // GEO:35
inline constexpr std::array<double, 3> phy = {kPi / 2 + kLegTilt, -kPi / 6 + kLegTilt,
                                              -5 * kPi / 6 + kLegTilt};  // GEO:36
// Degrees to radians as STA:307 writes it.
inline constexpr double kDegToRad = 0.0174532925;

// ---- Motor efforts (STA getForces, OLD getForces) ----
inline constexpr double kEffortPerNm = 10000.0;  // STA:276 (torque *= 10000), sign STA:277-279
inline constexpr double kStaMaxTorque = 30.0;    // STA:253, N m: the cap Barrow's code applies
// The cap libnifalcon documents ("capped at 4096": KIN:95, include/falcon/kinematic/
// FalconKinematicStamper.h:61) and OLD:49 applies per motor: clamp(-v, -4095, 4095).
inline constexpr int kDocumentedEffortCap = 4095;

// ---- Encoders (KIN getTheta) ----
// Degrees per encoder count, KIN:61: (shaft circumference / (4 x slots)) / (arm circumference /
// 360); angle = that x count + 35 degrees.
inline double theta_deg(double encoder) {
  const double arc_per_count = (kShaftD * kPi) / (kWheelSlots * 4);
  return arc_per_count * encoder / ((kPi * kSmallArmD) / 360.0) + kThetaOffset;
}
// Its inverse (real-valued; the emulator rounds).
inline double encoder_for_theta_deg(double deg) {
  return (deg - kThetaOffset) / (theta_deg(1.0) - theta_deg(0.0));
}

using V3 = std::array<double, 3>;
using M3 = std::array<std::array<double, 3>, 3>;  // [row][col]

struct Angles {
  V3 theta1{}, theta2{}, theta3{};  // STA uses float (include/falcon/kinematic/stamper/
                                    // StamperUtils.h:51-53); double here
};

// ---- Inverse kinematics, STA:28-94 ----
// False where STA's square roots or arc cosines have no real value (outside the reach).
inline bool ik(const V3& p, Angles& out) {
  for (int i = 0; i < 3; ++i) {
    const double cp = std::cos(phy[i]), sp = std::sin(phy[i]);
    // STA:32-41: P = R(phy) p + (-r, -s, 0), R = [[cos, sin, 0], [-sin, cos, 0], [0, 0, 1]]
    const double u = cp * p[0] + sp * p[1] - r;
    const double v = -sp * p[0] + cp * p[1] - s;
    const double w = p[2];
    // STA:56: theta3 = acos((v + f) / b)
    const double q3 = (v + f) / b;
    if (!(q3 > -1.0 && q3 < 1.0)) return false;
    const double t3 = std::acos(q3);
    const double s3 = std::sin(t3);
    // STA:64-66: l0, l1, l2 term by term
    const double common = w * w + u * u + 2 * c * u + a * a + c * c - d * d - e * e -
                          b * b * s3 * s3 - 2 * b * e * s3 - 2 * b * d * s3 - 2 * d * e;
    const double l0 = common - 2 * a * u - 2 * a * c;
    const double l1 = -4 * a * w;
    const double l2 = common + 2 * a * u + 2 * a * c;
    // STA:81, the "b" root; STA:85: theta1 = 2 atan(T)
    const double disc = l1 * l1 - 4 * l0 * l2;
    if (!(disc >= 0.0) || l2 == 0.0) return false;
    const double T = (-l1 - std::sqrt(disc)) / (2 * l2);
    const double t1 = std::atan(T) * 2;
    // STA:91: theta2 = acos((-u + a cos t1 - c) / (-d - e - b sin t3))
    const double q2 = (-u + a * std::cos(t1) - c) / (-d - e - b * s3);
    if (!(q2 >= -1.0 && q2 <= 1.0)) return false;
    out.theta1[i] = t1;
    out.theta2[i] = std::acos(q2);
    out.theta3[i] = t3;
  }
  return true;
}

enum class JzForm { Printed, Derived };

// ---- The Jacobian d theta1 / d p, STA:101-132 (before STA:135 inverts it) ----
inline M3 dtheta_dp(const Angles& q, JzForm form = JzForm::Derived) {
  M3 J{};
  for (int i = 0; i < 3; ++i) {
    const double t1 = q.theta1[i], t2 = q.theta2[i], t3 = q.theta3[i];
    // STA:109: den = -a sin t3 (sin t1 cos t2 - sin t2 cos t1)
    const double den =
        -a * std::sin(t3) * (std::sin(t1) * std::cos(t2) - std::sin(t2) * std::cos(t1));
    // STA:111-112
    J[i][0] = std::cos(phy[i]) * std::cos(t2) * std::sin(t3) / den -
              std::sin(phy[i]) * std::cos(t3) / den;
    J[i][1] = std::sin(phy[i]) * std::cos(t2) * std::sin(t3) / den +
              std::cos(phy[i]) * std::cos(t3) / den;
    // STA:113 as printed, or as derived (see the head of this file)
    J[i][2] = form == JzForm::Printed ? std::sin(t2) * std::sin(t2) / den
                                      : std::sin(t2) * std::sin(t3) / den;
  }
  return J;
}

inline bool invert(const M3& m, M3& out) {
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  if (!std::isfinite(det) || det == 0.0) return false;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      // cofactor of (j, i), cyclic indices
      const int r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3, c1 = (i + 2) % 3;
      out[i][j] = (m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]) / det;
    }
  return true;
}

inline V3 times(const M3& m, const V3& v) {
  V3 o{};
  for (int i = 0; i < 3; ++i) o[i] = m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2];
  return o;
}
inline V3 transposed_times(const M3& m, const V3& v) {
  V3 o{};
  for (int i = 0; i < 3; ++i) o[i] = m[0][i] * v[0] + m[1][i] * v[1] + m[2][i] * v[2];
  return o;
}

// ---- Forward kinematics, STA:149-225: Newton-Raphson on the inverse kinematics ----
// STA stops at |theta1 error| < 0.01 rad (STA:158) within 15 tries (STA:161), halving its step
// (from 0.5, STA:160) on an overshoot (STA:212-216). Those are arguments here: the tests ask for
// far tighter agreement than STA's 0.01 rad. False when it does not get there.
inline bool fk(const V3& theta1, V3& pos, double target_error = 0.01, int max_tries = 15,
               JzForm form = JzForm::Derived) {
  V3 p = pos;
  double previous_error = 10000.0, gain = 0.5;
  for (int i = 0; i < max_tries; ++i) {
    Angles q;
    M3 Jinv;
    if (!ik(p, q) || !invert(dtheta_dp(q, form), Jinv)) return false;
    const V3 delta{theta1[0] - q.theta1[0], theta1[1] - q.theta1[1], theta1[2] - q.theta1[2]};
    const V3 step = times(Jinv, delta);                  // STA:181
    for (int k = 0; k < 3; ++k) p[k] += gain * step[k];  // STA:191-193
    // STA:197-210: the error is that of the guess it stepped from; the stepped guess is returned
    const double error = std::sqrt(delta[0] * delta[0] + delta[1] * delta[1] + delta[2] * delta[2]);
    if (error < target_error) {
      pos = p;
      return true;
    }
    if (error > previous_error) gain /= 2.0;
    previous_error = error;
  }
  return false;
}

// ---- Force -> motor efforts, STA:227-282 ----
// torque = (J^-1)^T F (STA:241-245), all three scaled by one factor when the largest exceeds
// max_torque_Nm (STA:253-270), efforts = -10000 torque (STA:276-279). STA passes kStaMaxTorque
// (30 N m); the value as a double, before STA's conversion to int.
inline bool efforts(const V3& p, const V3& force, V3& out, double max_torque_Nm = kStaMaxTorque,
                    JzForm form = JzForm::Derived) {
  Angles q;
  M3 Jinv;
  if (!ik(p, q) || !invert(dtheta_dp(q, form), Jinv)) return false;
  V3 torque = transposed_times(Jinv, force);
  double largest = 0.0;
  for (const double t : torque) largest = std::fmax(largest, std::fabs(t));
  if (largest > max_torque_Nm)
    for (double& t : torque) t /= largest / max_torque_Nm;
  for (int i = 0; i < 3; ++i) out[i] = -torque[i] * kEffortPerNm;
  return true;
}

// What the motors push on the handle for given efforts: the inverse of the map above,
// F = J^T torque with J = d theta1 / d p and torque = -effort / 10000 (STA:276-279 undone).
inline bool force_from_efforts(const V3& p, const V3& effort, V3& force,
                               JzForm form = JzForm::Derived) {
  Angles q;
  if (!ik(p, q)) return false;
  const V3 torque{-effort[0] / kEffortPerNm, -effort[1] / kEffortPerNm, -effort[2] / kEffortPerNm};
  force = transposed_times(dtheta_dp(q, form), torque);
  return std::isfinite(force[0]) && std::isfinite(force[1]) && std::isfinite(force[2]);
}

}  // namespace palp::falconref
