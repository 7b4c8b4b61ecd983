// The structure layer: the scene's vessels, artery and organs (RenderVolume::labels) ray cast as a
// volume of their own over the body, each in its colour (structure_style.hpp), the artery's colour
// and opacity beating with the stream's pulse_wave, and the legend naming them (text in each
// structure's colour, bottom right). Shown with the `vessels` preset only; without labels nothing
// is drawn and nothing changes.
//
// The labels are sampled nearest-neighbour (a label between two others is no structure), unshaded;
// the layer follows the render volume's placement (origin, spacing) but not its deformation.
#pragma once

#include <vtkColorTransferFunction.h>
#include <vtkGPUVolumeRayCastMapper.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPiecewiseFunction.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>
#include <vtkTextActor.h>
#include <vtkUnsignedCharArray.h>
#include <vtkVolume.h>
#include <vtkVolumeProperty.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "render/structure_style.hpp"
#include "stream/stream_client.hpp"

namespace palp::view {

class StructureLayer {
 public:
  explicit StructureLayer(vtkRenderer* renderer);

  // Takes `volume`'s labels and the scene's structures (none, or labels that do not match the
  // volume's size: nothing drawn). Called with every new render volume.
  void load(const RenderVolume& volume, const SceneDescription* scene);
  // The artery's beat (0 diastole .. 1 systole) and the rate for the legend (unset: not said).
  void set_pulse(double wave, const std::optional<double>& bpm);
  // Shown (the vessels preset) or hidden; `legend`: the legend too (the HUD's overlays).
  void set_visible(bool visible, bool legend);

  bool has_structures() const { return !styles_.empty(); }
  bool visible() const { return visible_; }
  const std::vector<StructureStyle>& styles() const { return styles_; }
  // The legend's lines as drawn (empty without structures).
  const std::vector<std::string>& legend() const { return legend_; }

 private:
  void apply_styles();
  void update_legend();

  vtkRenderer* renderer_;
  std::vector<std::uint8_t> labels_;  // the texture's data (the array wraps it, no copy)
  vtkNew<vtkImageData> image_;
  vtkNew<vtkUnsignedCharArray> label_array_;
  vtkNew<vtkGPUVolumeRayCastMapper> mapper_;
  vtkNew<vtkVolumeProperty> property_;
  vtkNew<vtkColorTransferFunction> colour_;
  vtkNew<vtkPiecewiseFunction> opacity_;
  vtkNew<vtkVolume> volume_;
  std::vector<vtkSmartPointer<vtkTextActor>> legend_actors_;
  std::vector<StructureStyle> styles_;
  std::vector<std::string> legend_;
  double wave_ = 1.0;  // as drawn
  std::optional<double> bpm_;
  bool visible_ = false, legend_visible_ = false;
};

}  // namespace palp::view
