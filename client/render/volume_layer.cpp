// The volume layer: ray-cast volume, transfer functions, deformed texture (volume_layer.hpp).
#include "render/volume_layer.hpp"

#include <vtkPointData.h>

#include <algorithm>

namespace palp::view {

VolumeLayer::VolumeLayer(vtkRenderer* renderer, PresetId preset, bool deformation,
                         const DeformerParams& deformer)
    : deformation_(deformation),
      deformer_params_(deformer),
      preset_(make_preset(preset)),
      window_level_(preset_.window) {
  // The pipeline (its input arrives with the volume).
  mapper_->AutoAdjustSampleDistancesOff();
  mapper_->SetBlendModeToComposite();
  property_->SetColor(colour_);
  property_->SetScalarOpacity(opacity_);
  property_->SetInterpolationTypeToLinear();
  property_->SetAmbient(0.25);
  property_->SetDiffuse(0.75);
  property_->SetSpecular(0.15);
  property_->SetSpecularPower(20.0);
  volume_->SetMapper(mapper_);
  volume_->SetProperty(property_);
  volume_->VisibilityOff();
  renderer->AddVolume(volume_);
  apply_preset();
}

bool VolumeLayer::is_new(const LatestState& state) const {
  return state.volume && (state.volume != seen_ || state.connection != connection_);
}

bool VolumeLayer::load(const LatestState& state) {
  seen_ = state.volume;
  connection_ = state.connection;
  const RenderVolume& source = *state.volume;
  const std::int64_t n = source.dims[0] * source.dims[1] * source.dims[2];
  // A volume whose arrays do not match its dimensions is never kept: everything that samples
  // source() (the shadow, the deformer) indexes by the dimensions.
  if (n <= 0 || static_cast<std::int64_t>(source.d_surf.size()) != n ||
      (!source.d_bone.empty() && static_cast<std::int64_t>(source.d_bone.size()) != n))
    return false;
  source_ = state.volume;
  render_scalars_ = compose_render_scalar(source.d_surf, source.d_bone);
  image_->SetDimensions(static_cast<int>(source.dims[0]), static_cast<int>(source.dims[1]),
                        static_cast<int>(source.dims[2]));
  image_->SetSpacing(source.spacing[0], source.spacing[1], source.spacing[2]);
  image_->SetOrigin(0, 0, 0);
  scalar_array_->SetName("render_scalar");
  scalar_array_->SetNumberOfComponents(1);
  // No copy: the array reads render_scalars_, which the deformer writes in place.
  scalar_array_->SetArray(render_scalars_.data(), n, 1);
  image_->GetPointData()->SetScalars(scalar_array_);
  scalar_array_->Modified();
  image_->Modified();
  mapper_->SetInputData(image_);
  mapper_->SetSampleDistance(0.5 *
                             std::min({source.spacing[0], source.spacing[1], source.spacing[2]}));
  volume_->VisibilityOn();
  deformer_ = deformation_ ? std::make_unique<SkinDeformer>(source.dims, source.spacing,
                                                            render_scalars_, deformer_params_)
                           : nullptr;
  return true;
}

void VolumeLayer::set_contacts(const FrameState& frame) {
  deform_contacts_.clear();
  if (frame.valid)
    for (const ContactState& c : frame.contacts)
      if (c.in_contact) deform_contacts_.push_back({c.x, c.p});
}

DeformResult VolumeLayer::deform() {
  if (!deformer_ || render_scalars_.empty()) return {};
  const DeformResult result = deformer_->update(deform_contacts_, render_scalars_);
  // Anything written (a new ROI, or the last one restored): the texture must be re-uploaded.
  if (result.active || deform_was_active_) {
    scalar_array_->Modified();
    image_->Modified();
  }
  deform_was_active_ = result.active;
  return result;
}

void VolumeLayer::apply_preset() {
  colour_->RemoveAllPoints();
  opacity_->RemoveAllPoints();
  for (const ControlPoint& point : preset_.points) {
    const double v = point_value(point, window_level_);
    colour_->AddRGBPoint(v, point.rgb[0], point.rgb[1], point.rgb[2]);
    opacity_->AddPoint(v, point.opacity);
  }
  property_->SetShade(preset_.shade ? 1 : 0);
}

void VolumeLayer::set_preset(PresetId id) {
  preset_ = make_preset(id);
  window_level_ = preset_.window;
  apply_preset();
}

void VolumeLayer::adjust_window(double dlevel, double width_factor) {
  window_level_ = palp::view::adjust_window(window_level_, dlevel, width_factor);
  apply_preset();
}

}  // namespace palp::view
