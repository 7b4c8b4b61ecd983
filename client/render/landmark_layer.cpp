// The landmarks layer: see landmark_layer.hpp.
#include "render/landmark_layer.hpp"

#include <vtkGlyph3D.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkProperty.h>
#include <vtkSphereSource.h>
#include <vtkTextProperty.h>

#include <set>
#include <string>

#include "render/glyph_geometry.hpp"

namespace palp::view {

namespace {
constexpr std::size_t kMaxLabels = 128;  // one per name; a rib's points share one
}

bool landmarks_shown(const LatestState& state, bool wanted) {
  if (!wanted || !state.landmarks || state.landmarks->empty()) return false;
  return !state.task || state.task->show_landmarks;
}

LandmarkLayer::LandmarkLayer(vtkRenderer* renderer) : renderer_(renderer) {}

void LandmarkLayer::build(const std::vector<LandmarkPoint>& points) {
  if (spheres_) renderer_->RemoveActor(spheres_);
  for (const auto& label : labels_) renderer_->RemoveActor(label);
  labels_.clear();
  vtkNew<vtkPoints> xyz;
  for (const LandmarkPoint& p : points) xyz->InsertNextPoint(p.point.x, p.point.y, p.point.z);
  vtkNew<vtkPolyData> cloud;
  cloud->SetPoints(xyz);
  vtkNew<vtkSphereSource> sphere;
  sphere->SetRadius(2.5);
  sphere->SetThetaResolution(12);
  sphere->SetPhiResolution(8);
  vtkNew<vtkGlyph3D> glyphs;
  glyphs->SetInputData(cloud);
  glyphs->SetSourceConnection(sphere->GetOutputPort());
  glyphs->Update();
  spheres_ = make_actor(glyphs->GetOutput(), false);
  spheres_->GetProperty()->SetColor(1.0, 0.85, 0.1);
  renderer_->AddActor(spheres_);
  std::set<std::string> named;
  for (const LandmarkPoint& p : points) {
    if (labels_.size() == kMaxLabels || !named.insert(p.name).second) continue;
    auto label = vtkSmartPointer<vtkBillboardTextActor3D>::New();
    label->SetInput(p.name.c_str());
    label->SetPosition(p.point.x, p.point.y, p.point.z);
    label->GetTextProperty()->SetFontSize(14);
    label->GetTextProperty()->SetColor(1.0, 0.9, 0.3);
    label->SetDisplayOffset(6, 6);
    renderer_->AddActor(label);
    labels_.push_back(label);
  }
}

void LandmarkLayer::update(const LatestState& state, bool wanted) {
  if (state.landmarks && state.landmarks.get() != built_) {
    keep_ = state.landmarks;
    built_ = keep_.get();
    build(*keep_);
  }
  visible_ = landmarks_shown(state, wanted);
  if (spheres_) spheres_->SetVisibility(visible_);
  for (const auto& label : labels_) label->SetVisibility(visible_);
}

}  // namespace palp::view
