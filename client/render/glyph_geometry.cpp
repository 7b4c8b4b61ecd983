// Geometry helpers shared by the tool layer and the fingertip's shadow (see glyph_geometry.hpp).
#include "render/glyph_geometry.hpp"

#include <vtkNew.h>
#include <vtkPolyDataMapper.h>

#include <cmath>

namespace palp::view {

vtkSmartPointer<vtkMatrix4x4> frame_matrix(const Vec3d& origin, Vec3d direction, int along_axis,
                                           const Vec3d& scale) {
  const double n = norm(direction);
  direction = n > 0 ? direction * (1.0 / n) : Vec3d{0, 0, 1};
  const Vec3d helper = std::abs(direction.x) < 0.9 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
  Vec3d a = cross(direction, helper);
  a = a * (1.0 / norm(a));
  const Vec3d b = cross(direction, a);
  Vec3d cols[3];
  if (along_axis == 0) {
    cols[0] = direction, cols[1] = a, cols[2] = b;
  } else {
    cols[0] = a, cols[1] = b, cols[2] = direction;
  }
  const double s[3] = {scale.x, scale.y, scale.z};
  auto m = vtkSmartPointer<vtkMatrix4x4>::New();
  for (int c = 0; c < 3; ++c) {
    m->SetElement(0, c, cols[c].x * s[c]);
    m->SetElement(1, c, cols[c].y * s[c]);
    m->SetElement(2, c, cols[c].z * s[c]);
  }
  m->SetElement(0, 3, origin.x);
  m->SetElement(1, 3, origin.y);
  m->SetElement(2, 3, origin.z);
  return m;
}

vtkSmartPointer<vtkActor> make_actor(vtkPolyData* poly, bool scalar_colours) {
  vtkNew<vtkPolyDataMapper> mapper;
  mapper->SetInputData(poly);
  mapper->SetScalarVisibility(scalar_colours);
  if (scalar_colours) mapper->SetColorModeToDirectScalars();
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  return actor;
}

}  // namespace palp::view
