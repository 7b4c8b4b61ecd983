// Where a device sits on the patient: the registration from the device's frame to the scene.
//
//   scene point  = home + scale · R · device point        (mm; R a rotation, or a mirror when
//   scene turn   = R ∘ device turn                           the CT is stored mirrored)
//   device force = Rᵀ · scene force                       (N: the hand feels the model's newtons)
//   device torque = det(R) · Rᵀ · scene torque / scale    (N·mm: moment arms shrink by scale)
//
// R is given in patient terms: the patient directions the device's +x, +y and +z point to
// ("IAR": x toward inferior, y toward anterior, z toward the patient's right: a desk device with
// y up, z toward the user, placed at the patient's right side of a supine patient). The home point
// is where the device's origin (the centre of its workspace) lands in the scene. Pure: the loop
// applies it between the device and the model every tick.
#pragma once

#include <array>
#include <string>
#include <string_view>

#include "base/patient_frame.hpp"
#include "base/vec.hpp"

namespace palp {

struct Registration {
  std::array<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major, device -> scene
  double scale = 1.0;                                         // scene mm per device mm
  Vec3d home{};  // scene mm: where the device origin lands
  bool is_identity() const;
};

// R with columns frame.toward(axes[0..2]): the device's x, y, z in patient terms. UsageError for
// three letters that are not one of each pair (L/R, P/A, S/I).
std::array<double, 9> rotation_from_axes(const PatientFrame& frame, std::string_view axes);

Pose to_scene(const Registration& r, const Pose& device);
// home + scale · R · device point: where a device point lands in the scene.
Vec3d point_to_scene(const Registration& r, const Vec3d& device_point);
Vec3d scene_point_to_device(const Registration& r, const Vec3d& scene_point);
Vec3d force_to_device(const Registration& r, const Vec3d& scene_force);
Vec3d force_to_scene(const Registration& r, const Vec3d& device_force);
Vec3d torque_to_device(const Registration& r, const Vec3d& scene_torque);
Vec3d torque_to_scene(const Registration& r, const Vec3d& device_torque);

// Can the device press `depth_mm` below the skin point `skin` (outward normal `normal`, scene)?
// The device point needed there, in the device frame, must lie inside its workspace box
// (±workspace_half_mm about the device origin). Empty when it can; else what is missing and what
// to change, for people.
std::string check_reach(const Registration& r, const Vec3d& skin, const Vec3d& normal,
                        const Vec3d& workspace_half_mm, double depth_mm);

}  // namespace palp
