// Geometry helpers shared by the tool layer and the fingertip's shadow: frame matrices, actors.
#pragma once

#include <vtkActor.h>
#include <vtkMatrix4x4.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>

#include "base/vec.hpp"

namespace palp::view {

// A matrix mapping +x (along_axis 0: arrow) or +z (along_axis 2: disk) to `direction`, the
// three axes scaled by `scale`, at `origin`.
vtkSmartPointer<vtkMatrix4x4> frame_matrix(const Vec3d& origin, Vec3d direction, int along_axis,
                                           const Vec3d& scale);

// An actor drawing `poly`; with `scalar_colours` its point scalars are the RGB colours.
vtkSmartPointer<vtkActor> make_actor(vtkPolyData* poly, bool scalar_colours);

}  // namespace palp::view
