// Where OpenIGTLink puts palp's poses and vectors: the CT file's own patient frame, in RAS (what
// 3D Slicer and every OpenIGTLink receiver assume), so that the tool lands on the CT when the same
// file is loaded in Slicer.
//
//   scene x (mm)  --[D | origin]-->  LPS world w = origin + D x  --diag(-1,-1,1)-->  RAS
//
// D is the file's direction (columns: where i, j, k point, in LPS), origin the centre of voxel
// (0,0,0) in LPS (docs/frames.md). A NIfTI's sform, which maps voxel indices straight to RAS, is
// the same map with the spacing folded in: sform = RAS_from_scene * diag(spacing, 1).
#pragma once

#include <array>

#include "base/vec.hpp"
#include "base/volume.hpp"

namespace palp::interop {

// Row-major 4x4 rigid transform (rotation and translation in mm).
using Matrix4 = std::array<std::array<double, 4>, 4>;

// The scene -> RAS map of a grid: rotation part F D, translation F origin (F = diag(-1,-1,1)).
Matrix4 ras_from_scene(const Grid& grid);

// A device pose (tool frame -> scene frame) as a tool -> RAS transform.
Matrix4 ras_pose(const Matrix4& ras_from_scene, const Pose& pose);

// A free vector of the scene frame (a force, a displacement) in RAS axes (no translation).
Vec3d ras_vector(const Matrix4& ras_from_scene, const Vec3d& v);

}  // namespace palp::interop
