// The scan's landmarks in palpview (issue 40): glyph spheres at their points and a label per
// name, for the instructor. Shown when asked (the L key) and palpd allows it: never to the
// trainee's controller while a task runs (TaskInfo::show_landmarks).
#pragma once

#include <memory>
#include <vector>

#include <vtkActor.h>
#include <vtkBillboardTextActor3D.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>

#include "stream/stream_client.hpp"

namespace palp::view {

// Whether the landmarks may be drawn now: asked for, received, and allowed by palpd (a palpd
// without tasks says nothing: allowed).
bool landmarks_shown(const LatestState& state, bool wanted);

class LandmarkLayer {
 public:
  explicit LandmarkLayer(vtkRenderer* renderer);
  void update(const LatestState& state, bool wanted);
  bool visible() const { return visible_; }

 private:
  void build(const std::vector<LandmarkPoint>& points);
  vtkRenderer* renderer_;
  vtkSmartPointer<vtkActor> spheres_;
  std::vector<vtkSmartPointer<vtkBillboardTextActor3D>> labels_;
  const std::vector<LandmarkPoint>* built_ = nullptr;
  std::shared_ptr<const std::vector<LandmarkPoint>> keep_;
  bool visible_ = false;
};

}  // namespace palp::view
