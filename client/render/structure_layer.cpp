// The structure layer: see structure_layer.hpp.
#include "render/structure_layer.hpp"

#include <vtkPointData.h>
#include <vtkTextProperty.h>

#include <algorithm>
#include <cmath>

namespace palp::view {
namespace {

constexpr double kPlateau = 0.3;        // each label's colour holds over label +- this
constexpr double kWaveStep = 1.0 / 64;  // the transfer functions follow the wave in these steps
constexpr double kLegendLineHeight = 0.035;  // normalized viewport, between the legend's lines

}  // namespace

StructureLayer::StructureLayer(vtkRenderer* renderer) : renderer_(renderer) {
  mapper_->AutoAdjustSampleDistancesOff();
  mapper_->SetBlendModeToComposite();
  property_->SetColor(colour_);
  property_->SetScalarOpacity(opacity_);
  property_->SetInterpolationTypeToNearest();
  property_->ShadeOff();
  volume_->SetMapper(mapper_);
  volume_->SetProperty(property_);
  volume_->VisibilityOff();
  renderer->AddVolume(volume_);
}

void StructureLayer::load(const RenderVolume& volume, const SceneDescription* scene) {
  const std::int64_t n = volume.dims[0] * volume.dims[1] * volume.dims[2];
  styles_.clear();
  if (scene && !scene->structures.empty() && n > 0 &&
      static_cast<std::int64_t>(volume.labels.size()) == n)
    styles_ = structure_styles(scene->structures);
  if (styles_.empty()) {
    labels_.clear();
    update_legend();
    set_visible(visible_, legend_visible_);
    return;
  }
  labels_ = volume.labels;
  image_->SetDimensions(static_cast<int>(volume.dims[0]), static_cast<int>(volume.dims[1]),
                        static_cast<int>(volume.dims[2]));
  image_->SetSpacing(volume.spacing[0], volume.spacing[1], volume.spacing[2]);
  image_->SetOrigin(volume.origin[0], volume.origin[1], volume.origin[2]);
  label_array_->SetName("structure_label");
  label_array_->SetNumberOfComponents(1);
  label_array_->SetArray(labels_.data(), n, 1);
  image_->GetPointData()->SetScalars(label_array_);
  label_array_->Modified();
  image_->Modified();
  mapper_->SetInputData(image_);
  mapper_->SetSampleDistance(0.5 *
                             std::min({volume.spacing[0], volume.spacing[1], volume.spacing[2]}));
  apply_styles();
  update_legend();
  set_visible(visible_, legend_visible_);
}

// Every label's colour and opacity as plateaus about its value, nothing at 0 and between labels.
void StructureLayer::apply_styles() {
  colour_->RemoveAllPoints();
  opacity_->RemoveAllPoints();
  colour_->AddRGBPoint(0.0, 0.0, 0.0, 0.0);
  opacity_->AddPoint(0.0, 0.0);
  for (const StructureStyle& base : styles_) {
    const StructureStyle s = pulsed(base, wave_);
    const double l = s.label;
    for (const double v : {l - kPlateau, l + kPlateau}) {
      colour_->AddRGBPoint(v, s.rgb[0], s.rgb[1], s.rgb[2]);
      opacity_->AddPoint(v, s.opacity);
    }
    opacity_->AddPoint(l - 0.5, 0.0);
    opacity_->AddPoint(l + 0.5, 0.0);
  }
}

void StructureLayer::set_pulse(double wave, const std::optional<double>& bpm) {
  const double w = std::isfinite(wave) ? std::clamp(wave, 0.0, 1.0) : 0.0;
  const double stepped = std::round(w / kWaveStep) * kWaveStep;
  if (bpm != bpm_) {
    bpm_ = bpm;
    update_legend();
  }
  if (stepped == wave_) return;
  wave_ = stepped;
  if (!styles_.empty()) apply_styles();
}

// One text actor a structure, in its colour (the artery's at systole), stacked bottom right.
void StructureLayer::update_legend() {
  std::vector<StructureStyle> shown;
  for (const StructureStyle& s : styles_) shown.push_back(pulsed(s, 1.0));
  legend_ = legend_lines(shown, bpm_);
  while (legend_actors_.size() < legend_.size()) {
    auto actor = vtkSmartPointer<vtkTextActor>::New();
    actor->GetTextProperty()->SetFontSize(15);
    actor->GetTextProperty()->SetBold(true);
    actor->GetTextProperty()->SetJustificationToRight();
    actor->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
    renderer_->AddActor2D(actor);
    legend_actors_.push_back(actor);
  }
  for (std::size_t i = 0; i < legend_actors_.size(); ++i) {
    vtkTextActor* actor = legend_actors_[i];
    if (i >= legend_.size()) {
      actor->VisibilityOff();
      continue;
    }
    const auto& rgb = shown[i].rgb;
    actor->GetTextProperty()->SetColor(rgb[0], rgb[1], rgb[2]);
    actor->SetInput(legend_[i].c_str());
    const double row = static_cast<double>(legend_.size() - 1 - i);
    actor->GetPositionCoordinate()->SetValue(0.985, 0.36 + kLegendLineHeight * row);
  }
}

void StructureLayer::set_visible(bool visible, bool legend) {
  visible_ = visible;
  legend_visible_ = legend;
  const bool drawn = visible && !styles_.empty();
  volume_->SetVisibility(drawn);
  for (std::size_t i = 0; i < legend_actors_.size(); ++i)
    legend_actors_[i]->SetVisibility(drawn && legend && i < legend_.size());
}

}  // namespace palp::view
