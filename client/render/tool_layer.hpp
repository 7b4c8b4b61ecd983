// The tool layer: tool, contact points, proxies, springs and the device force arrow.
//
// The tool is a fingertip, two fingertips or a probe, at its pose; the contact points are
// coloured by contact, the proxies joined to them by springs.
//
// All opaque geometry: VTK composites volumes over translucent geometry regardless of depth, so
// only opaque geometry (which writes the depth buffer the ray caster stops at) shows correctly in
// front of or inside the skin.
#pragma once

#include <vtkActor.h>
#include <vtkArrowSource.h>
#include <vtkNew.h>
#include <vtkPolyData.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>

#include <memory>
#include <string>

#include "stream/stream_client.hpp"

namespace palp::view {

// The tool (hand, finger, probe) is drawn semi-transparent, as in the paper: the skin, the
// contacts and proxies beneath it stay visible (sorted against the volume by depth peeling).
inline constexpr double kToolOpacity = 0.5;

class ToolLayer {
 public:
  // Adds its actors (hidden until a valid frame) to `renderer`; the arrow is
  // `arrow_mm_per_newton` long per newton of force.
  ToolLayer(vtkRenderer* renderer, double arrow_mm_per_newton);

  // Follows the state: the tool's geometry when the scene's tool changes, its pose, contacts,
  // proxies, springs and force arrow. `glyphs` false keeps them all hidden.
  void update(const LatestState& state, bool glyphs);
  // Hides every actor of the layer (until the next update with glyphs on).
  void hide();
  // The tool the geometry was built for ("" before the first scene that names one).
  const std::string& tool_name() const { return tool_name_; }

 private:
  double arrow_mm_per_newton_;
  std::string tool_name_;
  std::shared_ptr<const SceneDescription> scene_;
  vtkSmartPointer<vtkActor> tool_actor_;
  vtkNew<vtkPolyData> contact_poly_, proxy_poly_, spring_poly_;
  vtkSmartPointer<vtkActor> contact_actor_, proxy_actor_, spring_actor_;
  vtkNew<vtkArrowSource> arrow_source_;
  vtkSmartPointer<vtkActor> arrow_actor_;
};

}  // namespace palp::view
