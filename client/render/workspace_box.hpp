// The reach of a device placed on the patient: its workspace box, mapped through the
// registration (home + scale · R · corner), drawn as a wireframe with a line from the home point
// down to the skin, so a clinician sees where the hand can go. Hidden for scene-frame devices.
#pragma once

#include <vtkActor.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkRenderer.h>

#include <array>
#include <optional>

#include "stream/stream_client.hpp"

namespace palp::view {

// The eight corners of the box in the scene (corner c: x sign bit 0, y bit 1, z bit 2).
std::array<Vec3d, 8> workspace_corners(const SceneDescription::Placement& placement,
                                       const Vec3d& home);

class WorkspaceBox {
 public:
  explicit WorkspaceBox(vtkRenderer* renderer);
  // `home_now`: the home after re-centres (LinkStats), else the placement's.
  void update(const SceneDescription* scene, const std::optional<Vec3d>& home_now, bool visible);
  bool visible() const;

 private:
  vtkNew<vtkPoints> points_;
  vtkNew<vtkPolyData> lines_;
  vtkNew<vtkActor> actor_;
};

}  // namespace palp::view
