// Kinematics of the Novint Falcon, a 3-DOF delta robot (three parallelogram legs, one motor each).
//
// Geometry and conventions are the published ones of libnifalcon (BSD-3), after R. E. Stamper,
// "A three degree of freedom parallel manipulator with only translational degrees of freedom",
// PhD thesis, University of Maryland, 1997 (the diagram on p. 30 names a..f, r, s). The code here
// is palp's own derivation from those loop-closure equations (see falcon_kinematics.cpp):
//
//   leg i frame:  q = R(phi_i) p + (-r, -s, 0)      (p: device frame, mm; R: rotation about z)
//   closure:      u = a cos t1 - c + L cos t2,  w = a sin t1 + L sin t2,  v = b cos t3 - f,
//                 L = d + e + b sin t3                (t1: the motor's joint angle)
//
// Frames and units: the Falcon frame has x to the user's right, y up, z out of the device toward
// the user (libnifalcon's); palp's device frame is that frame shifted by kWorkspaceCentre, so the
// middle of the workspace is the origin. Positions mm, forces N, joint torques N mm.
//
//   encoder counts --joint_angle--> t1 (rad) --forward()--> position (Newton's method)
//   position --inverse()--> t1 ;  jacobian(): d t1 / d p (rad per mm)
//   force (N) --efforts()--> motor efforts (at most kMaxEffort, direction kept, never wrapped)
// Pure functions: no allocation, no state; safe in the real-time thread.
#pragma once

#include <array>
#include <cstdint>

#include "base/vec.hpp"

namespace palp::falcon {

// Published constants, each with its source.
// libnifalcon include/falcon/kinematic/FalconGeometry.h (Kevin Ouellet), after Stamper 1997 p. 30:
inline constexpr double kA = 60.0;    // mm, leg base to knee ("a")
inline constexpr double kB = 102.5;   // mm, shin parallelogram side ("b")
inline constexpr double kC = 14.43;   // mm, shin joint to effector centre, u component ("c")
inline constexpr double kD = 11.25;   // mm, shin to effector joint ("d")
inline constexpr double kE = kD;      // mm, knee to shin joint ("e" = d)
inline constexpr double kF = -25.0;   // mm, shin joint to effector centre, v component ("f")
inline constexpr double kR = 40.0;    // mm, frame origin to leg base, u component ("r")
inline constexpr double kS = -23.09;  // mm, frame origin to leg base, v component ("s")
inline constexpr double kPi = 3.14159265358979323846;
// Leg directions: 90, -30, -150 degrees plus the 15 degree tilt of every axis from the desk plane
// (same file, phy[] and OFFSET_ANGLE).
inline constexpr std::array<double, 3> kPhi = {kPi / 2 + kPi / 12, -kPi / 6 + kPi / 12,
                                               -5 * kPi / 6 + kPi / 12};
// Encoders (same file): 320 slots read in quadrature on the motor shaft (14.25 mm) driving the
// arm's capstan (110 mm); encoder 0 is about 35 degrees.
inline constexpr double kWheelSlots = 320.0;
inline constexpr double kShaftDiameter = 14.25;     // mm
inline constexpr double kSmallArmDiameter = 110.0;  // mm
inline constexpr double kThetaOffsetDeg = 35.0;
// Motor effort per joint torque: libnifalcon src/kinematic/FalconKinematicStamper.cpp getForces()
// sends -10000 x torque (N m) as the motor value, i.e. -10 per N mm.
inline constexpr double kEffortPerNmm = 10.0;
// The largest effort palp sends a motor. The frame carries a signed 16-bit value, but what
// Novint's firmware does with more than 12 bits is published nowhere: libnifalcon documents its
// efforts as "capped at 4096" (include/falcon/core/FalconKinematic.h:95,
// include/falcon/kinematic/FalconKinematicStamper.h:61, commit f7c727a) and the kinematics it
// shipped first clamp each motor to +-4095 (boneyard/ouellet_kinematics/
// FalconKinematicStamper.cpp:49), with the gain of 10000 per N m fitted to Novint's own driver
// (same file, :41-43). Its current kinematics cap the torque at 30 N m instead
// (src/kinematic/FalconKinematicStamper.cpp:253, "Rather random choice"), i.e. 300000 counts,
// which the 16-bit frame would wrap (src/firmware/FalconFirmwareNovintSDK.cpp:87-90). palp keeps
// to the documented cap. When a force needs more, all three efforts are scaled by one factor (as
// libnifalcon's current code does with its torque cap, FalconKinematicStamper.cpp:264-270) so the
// force keeps its direction, and the caller counts it. docs/devices.md charts the force this
// leaves across the workspace.
inline constexpr int kMaxEffort = 4095;
// The middle of the workspace in the Falcon frame (mm): libnifalcon's examples keep the handle
// near z = 0.11 m; the centre used here is the point where the three joint angles are equal and
// the handle is 110 mm out (palp's device origin).
inline constexpr Vec3d kWorkspaceCentre{0.0, 0.0, 110.0};
// The cube palp's tests and the round trip cover: +-kWorkspaceHalf mm about the centre (the
// Falcon's published workspace is about 4" x 4" x 4", i.e. +-50 mm).
inline constexpr double kWorkspaceHalf = 40.0;

struct Mat3 {
  std::array<double, 9> m{};  // row-major
  double operator()(int r, int c) const { return m[static_cast<std::size_t>(3 * r + c)]; }
  double& operator()(int r, int c) { return m[static_cast<std::size_t>(3 * r + c)]; }
};
Vec3d multiply(const Mat3& a, const Vec3d& v);
Vec3d multiply_transposed(const Mat3& a, const Vec3d& v);  // a^T v
// Inverse; false when singular (|det| below 1e-12 of the scale).
bool invert(const Mat3& a, Mat3& out);

// Encoder counts <-> joint angle t1 (radians).
double joint_angle(std::int32_t encoder);
double encoder_counts(double joint_angle_rad);  // real-valued: the emulator rounds

// Inverse kinematics in the Falcon frame (mm): the three motor angles. False outside the
// mechanism's reach (no real solution).
bool inverse(const Vec3d& falcon_position, Vec3d& joint_angles);
// d t1_i / d p_j (rad/mm), row i = leg i, at a reachable position. False outside the reach.
bool jacobian(const Vec3d& falcon_position, Mat3& d_angles_d_position);
// Forward kinematics (Falcon frame, mm) from the three joint angles by Newton's method, starting
// at `guess` (the previous position; kWorkspaceCentre at first). False when it does not converge
// to 1e-9 rad within 30 steps.
bool forward(const Vec3d& joint_angles, const Vec3d& guess, Vec3d& falcon_position);

// Joint torques (N mm) that render `force` (N) at the end effector at `falcon_position`:
// tau = J_p^T F with J_p = (d t / d p)^-1. False at a singular or unreachable position.
bool joint_torques(const Vec3d& falcon_position, const Vec3d& force, Vec3d& torque_Nmm);
// The Cartesian force (N) that joint torques (N mm) produce at the end effector: F = J^T tau.
bool end_effector_force(const Vec3d& falcon_position, const Vec3d& torque_Nmm, Vec3d& force);

struct Efforts {
  std::array<std::int16_t, 3> value{};
  bool clamped = false;  // the request exceeded max_effort (kMaxEffort) and was scaled down
};
// Motor efforts for `force` at the position: -kEffortPerNmm x torque, rounded, all three scaled
// by one factor when any exceeds `max_effort` (<= kMaxEffort). Zero when the position is
// unreachable or anything is not finite.
Efforts efforts_for_force(const Vec3d& falcon_position, const Vec3d& force,
                          int max_effort = kMaxEffort);
// The joint torques (N mm) the motors produce for efforts (what the emulated mechanism applies).
Vec3d torques_from_efforts(const std::array<std::int16_t, 3>& efforts);

}  // namespace palp::falcon
