// The fingertip's shadow: a dark ring on the skin below each finger pad, from the undeformed map.
//
// Opaque geometry, like the tool layer (see tool_layer.hpp for why).
#pragma once

#include <vtkActor.h>
#include <vtkDiskSource.h>
#include <vtkNew.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>

#include <string>
#include <vector>

#include "stream/stream_client.hpp"

namespace palp::view {

class FingertipShadow {
 public:
  // Adds one ring actor to `renderer` per pad, as the tools need them (none for the probe).
  explicit FingertipShadow(vtkRenderer* renderer);

  // Places the rings for `frame`'s pose of the tool `tool_name` over `volume` (null: none yet);
  // `glyphs` false keeps them hidden.
  void update(const FrameState& frame, const std::string& tool_name, const RenderVolume* volume,
              bool glyphs);
  // Hides every ring (until the next update with glyphs on).
  void hide();

 private:
  vtkRenderer* renderer_;  // owned by the scene, outlives the shadow
  vtkNew<vtkDiskSource> source_;
  std::vector<vtkSmartPointer<vtkActor>> actors_;
};

}  // namespace palp::view
