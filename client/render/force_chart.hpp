// The force chart: |f| and its components over the last seconds, in its own renderer.
//
// The chart's renderer is layer 1, the lower right corner of the window, drawn over the scene.
#pragma once

#include <vtkChartXY.h>
#include <vtkContextActor.h>
#include <vtkContextScene.h>
#include <vtkNew.h>
#include <vtkRenderer.h>
#include <vtkTable.h>

#include <vector>

#include "stream/stream_client.hpp"

namespace palp::view {

class ForceChart {
 public:
  // The chart spans the last `seconds` of force history.
  explicit ForceChart(double seconds);

  // The chart's renderer (layer 1), for the scene to add to its window.
  vtkRenderer* renderer() { return renderer_; }
  // Plots the newest `seconds` of `history` (oldest first).
  void update(const std::vector<ForceSample>& history);
  void set_visible(bool visible);

 private:
  double seconds_;
  vtkNew<vtkRenderer> renderer_;
  vtkNew<vtkContextActor> actor_;
  vtkNew<vtkContextScene> scene_;
  vtkNew<vtkChartXY> chart_;
  vtkNew<vtkTable> table_;
};

}  // namespace palp::view
