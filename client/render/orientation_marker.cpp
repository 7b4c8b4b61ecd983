// The patient-axes cube in the corner: see orientation_marker.hpp.
#include "render/orientation_marker.hpp"

#include <vtkAnnotatedCubeActor.h>
#include <vtkCamera.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>

#include <string>

namespace palp::view {

OrientationMarker::OrientationMarker() {
  renderer_->SetViewport(0.0, 0.0, 0.14, 0.25);
  renderer_->SetLayer(1);
  renderer_->InteractiveOff();
  cube_->SetFaceTextScale(0.65);
  cube_->GetCubeProperty()->SetColor(0.25, 0.28, 0.35);
  cube_->GetTextEdgesProperty()->SetColor(0.9, 0.9, 0.9);
  cube_->GetXPlusFaceProperty()->SetColor(1.0, 0.45, 0.45);
  cube_->GetXMinusFaceProperty()->SetColor(1.0, 0.45, 0.45);
  cube_->GetYPlusFaceProperty()->SetColor(0.5, 1.0, 0.5);
  cube_->GetYMinusFaceProperty()->SetColor(0.5, 1.0, 0.5);
  cube_->GetZPlusFaceProperty()->SetColor(0.5, 0.7, 1.0);
  cube_->GetZMinusFaceProperty()->SetColor(0.5, 0.7, 1.0);
  renderer_->AddActor(cube_);
  set_frame(PatientFrame{});
}

OrientationMarker::~OrientationMarker() = default;

void OrientationMarker::set_frame(const PatientFrame& frame) {
  const auto label = [&](int axis, bool plus) {
    const Anatomy a = frame.axis_direction(axis);
    return std::string(1, letter(plus ? a : opposite(a)));
  };
  cube_->SetXPlusFaceText(label(0, true).c_str());
  cube_->SetXMinusFaceText(label(0, false).c_str());
  cube_->SetYPlusFaceText(label(1, true).c_str());
  cube_->SetYMinusFaceText(label(1, false).c_str());
  cube_->SetZPlusFaceText(label(2, true).c_str());
  cube_->SetZMinusFaceText(label(2, false).c_str());
}

void OrientationMarker::follow(vtkCamera* main_camera) {
  double dop[3], up[3];
  main_camera->GetDirectionOfProjection(dop);
  main_camera->GetViewUp(up);
  vtkCamera* c = renderer_->GetActiveCamera();
  c->SetFocalPoint(0, 0, 0);
  c->SetPosition(-3.5 * dop[0], -3.5 * dop[1], -3.5 * dop[2]);
  c->SetViewUp(up);
  c->SetViewAngle(30.0);
  renderer_->ResetCameraClippingRange();
}

void OrientationMarker::set_visible(bool visible) {
  renderer_->SetDraw(visible);
}

}  // namespace palp::view
