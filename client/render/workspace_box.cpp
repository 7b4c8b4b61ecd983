// The registered device's workspace box in the scene: see workspace_box.hpp.
#include "render/workspace_box.hpp"

#include "model/registration.hpp"

#include <vtkCellArray.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>

namespace palp::view {

std::array<Vec3d, 8> workspace_corners(const SceneDescription::Placement& p, const Vec3d& home) {
  const Registration r{p.rotation, p.scale, home};
  std::array<Vec3d, 8> out{};
  for (int c = 0; c < 8; ++c) {
    const Vec3d d{(c & 1) ? p.workspace_half_mm.x : -p.workspace_half_mm.x,
                  (c & 2) ? p.workspace_half_mm.y : -p.workspace_half_mm.y,
                  (c & 4) ? p.workspace_half_mm.z : -p.workspace_half_mm.z};
    out[static_cast<std::size_t>(c)] = point_to_scene(r, d);
  }
  return out;
}

WorkspaceBox::WorkspaceBox(vtkRenderer* renderer) {
  points_->SetNumberOfPoints(10);  // 8 corners, the home point, the skin below it
  vtkNew<vtkCellArray> cells;
  const int edges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                            {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
  for (const auto& e : edges) {
    const vtkIdType ids[2] = {e[0], e[1]};
    cells->InsertNextCell(2, ids);
  }
  const vtkIdType reach[2] = {8, 9};
  cells->InsertNextCell(2, reach);
  lines_->SetPoints(points_);
  lines_->SetLines(cells);
  vtkNew<vtkPolyDataMapper> mapper;
  mapper->SetInputData(lines_);
  actor_->SetMapper(mapper);
  actor_->GetProperty()->SetColor(1.0, 0.85, 0.3);
  actor_->GetProperty()->SetLineWidth(1.5);
  actor_->VisibilityOff();
  renderer->AddActor(actor_);
}

void WorkspaceBox::update(const SceneDescription* scene, const std::optional<Vec3d>& home_now,
                          bool visible) {
  if (!scene || !scene->placement || !visible) {
    actor_->VisibilityOff();
    return;
  }
  const SceneDescription::Placement& p = *scene->placement;
  const Vec3d home = home_now.value_or(p.home);
  const std::array<Vec3d, 8> corners = workspace_corners(p, home);
  for (int c = 0; c < 8; ++c) points_->SetPoint(c, corners[c].x, corners[c].y, corners[c].z);
  points_->SetPoint(8, home.x, home.y, home.z);
  const Vec3d skin = p.home_skin + (home - p.home);  // re-centring moves the whole box
  points_->SetPoint(9, skin.x, skin.y, skin.z);
  points_->Modified();
  actor_->VisibilityOn();
}

bool WorkspaceBox::visible() const {
  return actor_->GetVisibility() != 0;
}

}  // namespace palp::view
