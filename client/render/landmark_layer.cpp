// The landmarks layer: see landmark_layer.hpp.
#include "render/landmark_layer.hpp"

#include <vtkCoordinate.h>
#include <vtkGlyph3D.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkProperty.h>
#include <vtkSphereSource.h>
#include <vtkTextProperty.h>

#include <map>
#include <string>

#include "render/glyph_geometry.hpp"

namespace palp::view {

namespace {

constexpr const char* kSpinous = " spinous";  // palpd's name for a vertebra's tip: "L3 spinous"
constexpr int kFontPx = 17;
constexpr double kOffsetPx = 7.0;

bool ends_with(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

vtkSmartPointer<vtkTextActor> make_label(const LandmarkLabel& l) {
  auto label = vtkSmartPointer<vtkTextActor>::New();
  label->SetInput(l.text.c_str());
  vtkTextProperty* text = label->GetTextProperty();
  text->SetFontSize(kFontPx);
  text->BoldOn();
  text->SetColor(1.0, 0.9, 0.3);
  text->SetBackgroundColor(0.05, 0.05, 0.08);
  text->SetBackgroundOpacity(0.6);
  text->SetJustification(l.left ? VTK_TEXT_RIGHT : VTK_TEXT_LEFT);
  text->SetVerticalJustificationToCentered();
  // anchored at the 3-D point, offset in pixels beside it
  vtkNew<vtkCoordinate> anchor;
  anchor->SetCoordinateSystemToWorld();
  anchor->SetValue(l.at.x, l.at.y, l.at.z);
  vtkCoordinate* position = label->GetPositionCoordinate();
  position->SetCoordinateSystemToDisplay();
  position->SetReferenceCoordinate(anchor);
  position->SetValue(l.left ? -kOffsetPx : kOffsetPx, 0.0);
  return label;
}

}  // namespace

std::vector<LandmarkLabel> landmark_labels(const std::vector<LandmarkPoint>& points) {
  std::map<std::string, std::vector<Vec3d>> by_name;
  std::map<std::string, std::string> kind;
  std::vector<std::string> order;  // first appearance
  for (const LandmarkPoint& p : points) {
    auto [it, fresh] = by_name.try_emplace(p.name);
    if (fresh) order.push_back(p.name), kind[p.name] = p.kind;
    it->second.push_back(p.point);
  }
  std::vector<LandmarkLabel> out;
  for (const std::string& name : order) {
    if (out.size() == kMaxLandmarkLabels) break;
    const std::vector<Vec3d>& at = by_name.at(name);
    if (ends_with(name, kSpinous)) {
      const std::string vertebra = name.substr(0, name.size() - std::string(kSpinous).size());
      if (!by_name.count(vertebra)) out.push_back({vertebra, at.front(), false});
      continue;  // else the vertebra's label stands at this tip
    }
    const auto tip = by_name.find(name + kSpinous);
    Vec3d where = tip != by_name.end() ? tip->second.front() : at[at.size() / 2];
    if (kind[name] == "rib") where = at.back();  // its free end: lateral or in front
    out.push_back({name, where, kind[name] == "interspace"});
  }
  return out;
}

bool landmarks_shown(const LatestState& state, bool wanted) {
  if (!wanted || !state.landmarks || state.landmarks->empty()) return false;
  return !state.task || state.task->show_landmarks;
}

LandmarkLayer::LandmarkLayer(vtkRenderer* renderer) : renderer_(renderer) {}

void LandmarkLayer::build(const std::vector<LandmarkPoint>& points) {
  if (spheres_) renderer_->RemoveActor(spheres_);
  for (const auto& label : labels_) renderer_->RemoveActor2D(label);
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
  for (const LandmarkLabel& l : landmark_labels(points)) {
    labels_.push_back(make_label(l));
    renderer_->AddActor2D(labels_.back());
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
