// The scan's landmarks in palpview (issue 40): glyph spheres at their points and a label per
// name, for the instructor. Shown when asked (the L key) and palpd allows it: never to the
// trainee's controller while a task runs (TaskInfo::show_landmarks).
//
// The labels are 2-D text over the picture, anchored at their 3-D points (never hidden inside
// the volume), on a dark box so they read over white bone: a vertebra's at its spinous tip where
// palpd sends one (what the fingers find; "L3" and "L3 spinous" are one label), a rib's at its
// last point, the end away from the head (the ribs enter a scan's top edge side by side, their
// ends are spread), an interspace's to the left of its point (the vertebrae's go to the right),
// any other at its middle point.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <vtkActor.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>
#include <vtkTextActor.h>

#include "stream/stream_client.hpp"

namespace palp::view {

// Whether the landmarks may be drawn now: asked for, received, and allowed by palpd (a palpd
// without tasks says nothing: allowed).
bool landmarks_shown(const LatestState& state, bool wanted);

// A label to draw: its text, the point it names (scene frame mm) and which side of it.
struct LandmarkLabel {
  std::string text;
  Vec3d at{};
  bool left = false;  // the text ends left of the point (interspaces), else starts right of it
};

// One label per name (at most kMaxLandmarkLabels), placed as above; pure.
inline constexpr std::size_t kMaxLandmarkLabels = 128;
std::vector<LandmarkLabel> landmark_labels(const std::vector<LandmarkPoint>& points);

class LandmarkLayer {
 public:
  explicit LandmarkLayer(vtkRenderer* renderer);
  void update(const LatestState& state, bool wanted);
  bool visible() const { return visible_; }

 private:
  void build(const std::vector<LandmarkPoint>& points);
  vtkRenderer* renderer_;
  vtkSmartPointer<vtkActor> spheres_;
  std::vector<vtkSmartPointer<vtkTextActor>> labels_;
  const std::vector<LandmarkPoint>* built_ = nullptr;
  std::shared_ptr<const std::vector<LandmarkPoint>> keep_;
  bool visible_ = false;
};

}  // namespace palp::view
