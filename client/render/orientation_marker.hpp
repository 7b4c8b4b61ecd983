// The patient-axes cube radiology viewers show in a corner: faces labelled A/P, L/R, S/I through
// the scene's direction matrix, turned with the main camera every frame. Its own renderer, drawn
// over the scene (layer 1), in the bottom-left corner.
#pragma once

#include <vtkNew.h>

#include "base/patient_frame.hpp"

class vtkAnnotatedCubeActor;
class vtkCamera;
class vtkRenderer;
class vtkRenderWindow;

namespace palp::view {

class OrientationMarker {
 public:
  OrientationMarker();
  ~OrientationMarker();
  vtkRenderer* renderer() const { return renderer_; }
  // Labels the cube's faces for `frame` (the scene's +x face is the direction index i grows to).
  void set_frame(const PatientFrame& frame);
  // Looks at the cube from the direction the main camera looks at the scene.
  void follow(vtkCamera* main_camera);
  void set_visible(bool visible);

 private:
  vtkNew<vtkRenderer> renderer_;
  vtkNew<vtkAnnotatedCubeActor> cube_;
};

}  // namespace palp::view
