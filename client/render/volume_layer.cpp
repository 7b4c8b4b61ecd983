// The volume layer: ray-cast volume, transfer functions, deformed texture (volume_layer.hpp).
#include "render/volume_layer.hpp"

#include <vtkOpenGLGPUVolumeRayCastMapper.h>
#include <vtkOpenGLRenderWindow.h>
#include <vtkOpenGLState.h>
#include <vtkPointData.h>
#include <vtkTextureObject.h>
#include <vtkVolumeInputHelper.h>
#include <vtkVolumeTexture.h>
#include <vtk_glew.h>

#include <algorithm>

namespace palp::view {

VolumeLayer::VolumeLayer(vtkRenderer* renderer, PresetId preset, bool deformation,
                         const DeformerParams& deformer)
    : deformation_(deformation),
      deformer_params_(deformer),
      preset_(make_preset_on(palp::view::scalar_kind(preset, false, false), preset)),
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
  kind_ = palp::view::scalar_kind(preset, false, false);  // until a volume says what it has
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
      (!source.d_bone.empty() && static_cast<std::int64_t>(source.d_bone.size()) != n) ||
      (!source.hu.empty() && (static_cast<std::int64_t>(source.hu.size()) != n ||
                              static_cast<std::int64_t>(source.body.size()) != n)))
    return false;
  source_ = state.volume;
  const bool ct = !source.hu.empty();
  const ScalarKind kind = palp::view::scalar_kind(preset_.id, ct, skin_from_volume_);
  if (ct != ct_ || kind != kind_) {  // the presets follow what the scalar is
    ct_ = ct;
    kind_ = kind;
    preset_ = make_preset_on(kind, preset_.id);
    window_level_ = preset_.window;
    apply_preset();
  }
  image_->SetDimensions(static_cast<int>(source.dims[0]), static_cast<int>(source.dims[1]),
                        static_cast<int>(source.dims[2]));
  image_->SetSpacing(source.spacing[0], source.spacing[1], source.spacing[2]);
  image_->SetOrigin(source.origin[0], source.origin[1], source.origin[2]);
  mapper_->SetSampleDistance(0.5 *
                             std::min({source.spacing[0], source.spacing[1], source.spacing[2]}));
  compose();
  volume_->VisibilityOn();
  return true;
}

void VolumeLayer::compose() {
  const RenderVolume& source = *source_;
  const std::int64_t n = source.dims[0] * source.dims[1] * source.dims[2];
  switch (kind_) {
    case ScalarKind::Hu:
      render_scalars_ = compose_ct_scalar(source.hu, source.body, keep_outside_);
      break;
    case ScalarKind::Skin:
      render_scalars_ = compose_skin_scalar(source.d_surf, source.dims, source.spacing);
      break;
    case ScalarKind::Maps:
      render_scalars_ = compose_render_scalar(source.d_surf, source.d_bone);
      break;
  }
  scalar_array_->SetName("render_scalar");
  scalar_array_->SetNumberOfComponents(1);
  // No copy: the array reads render_scalars_, which the deformer writes in place.
  scalar_array_->SetArray(render_scalars_.data(), n, 1);
  image_->GetPointData()->SetScalars(scalar_array_);
  scalar_array_->Modified();
  image_->Modified();
  mapper_->SetInputData(image_);
  loaded_ = true;
  pending_lo_ = pending_hi_ = {};
  deformer_ = deformation_ ? std::make_unique<SkinDeformer>(source.dims, source.spacing,
                                                            render_scalars_, deformer_params_)
                           : nullptr;
}

void VolumeLayer::set_contacts(const FrameState& frame) {
  deform_contacts_.clear();
  // The deformer works on the volume's own voxels: (i, j, k) * spacing from its origin.
  const Vec3d origin =
      source_ ? Vec3d{source_->origin[0], source_->origin[1], source_->origin[2]} : Vec3d{};
  if (frame.valid)
    for (const ContactState& c : frame.contacts)
      if (c.in_contact) deform_contacts_.push_back({c.x - origin, c.p - origin});
}

DeformResult VolumeLayer::deform() {
  if (!deformer_ || render_scalars_.empty()) return {};
  const DeformResult result = deformer_->update(deform_contacts_, render_scalars_);
  // Anything written (a new ROI, or the last one restored): that box goes up at upload().
  const bool wrote =
      result.hi[0] > result.lo[0] && result.hi[1] > result.lo[1] && result.hi[2] > result.lo[2];
  if (wrote) {
    const bool had = pending_hi_[0] > pending_lo_[0];
    for (int a = 0; a < 3; ++a) {
      pending_lo_[a] = had ? std::min(pending_lo_[a], result.lo[a]) : result.lo[a];
      pending_hi_[a] = had ? std::max(pending_hi_[a], result.hi[a]) : result.hi[a];
    }
  }
  deform_was_active_ = result.active;
  return result;
}

std::int64_t VolumeLayer::upload(vtkRenderWindow* window) {
  const RenderVolume* v = source_.get();
  if (!v || render_scalars_.empty()) return 0;
  const std::int64_t whole = static_cast<std::int64_t>(render_scalars_.size() * sizeof(float));
  if (loaded_) {  // the next render loads the whole texture (with the ROI as written)
    loaded_ = false;
    pending_lo_ = pending_hi_ = {};
    return whole;
  }
  if (!(pending_hi_[0] > pending_lo_[0])) return 0;
  const std::array<std::int64_t, 3> lo = pending_lo_, hi = pending_hi_;
  pending_lo_ = pending_hi_ = {};
  // The mapper's one 3D texture (a single block: palpview never partitions the volume).
  vtkTextureObject* texture = nullptr;
  auto* gl_mapper = vtkOpenGLGPUVolumeRayCastMapper::SafeDownCast(mapper_.GetPointer());
  auto* gl_window = vtkOpenGLRenderWindow::SafeDownCast(window);
  if (gl_mapper && gl_window) {
    const auto input = gl_mapper->AssembledInputs.find(0);
    if (input != gl_mapper->AssembledInputs.end() && input->second.Texture) {
      vtkVolumeTexture::VolumeBlock* block = input->second.Texture->GetCurrentBlock();
      if (block && block->TextureObject && block->TextureObject->GetHandle() != 0 &&
          block->TextureSize[0] == v->dims[0] && block->TextureSize[1] == v->dims[1] &&
          block->TextureSize[2] == v->dims[2])
        texture = block->TextureObject;
    }
  }
  if (!texture) {  // fallback: the whole texture at the next render
    scalar_array_->Modified();
    image_->Modified();
    ++full_uploads_;
    return whole;
  }
  gl_window->MakeCurrent();
  vtkOpenGLState* state = gl_window->GetState();
  texture->Activate();
  state->vtkglPixelStorei(GL_UNPACK_ROW_LENGTH, static_cast<GLint>(v->dims[0]));
  state->vtkglPixelStorei(GL_UNPACK_IMAGE_HEIGHT, static_cast<GLint>(v->dims[1]));
  const std::size_t first =
      static_cast<std::size_t>(lo[0] + v->dims[0] * (lo[1] + v->dims[1] * lo[2]));
  glTexSubImage3D(GL_TEXTURE_3D, 0, static_cast<GLint>(lo[0]), static_cast<GLint>(lo[1]),
                  static_cast<GLint>(lo[2]), static_cast<GLsizei>(hi[0] - lo[0]),
                  static_cast<GLsizei>(hi[1] - lo[1]), static_cast<GLsizei>(hi[2] - lo[2]),
                  texture->GetFormat(VTK_FLOAT, 1, false), texture->GetDataType(VTK_FLOAT),
                  render_scalars_.data() + first);
  state->vtkglPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  state->vtkglPixelStorei(GL_UNPACK_IMAGE_HEIGHT, 0);
  texture->Deactivate();
  return (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]) *
         static_cast<std::int64_t>(sizeof(float));
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
  const ScalarKind kind = palp::view::scalar_kind(id, ct_, skin_from_volume_);
  preset_ = make_preset_on(kind, id);
  window_level_ = preset_.window;
  apply_preset();
  if (kind != kind_) {  // another scalar: composed again from the volume (when there is one)
    kind_ = kind;
    if (source_) compose();
  }
}

void VolumeLayer::adjust_window(double dlevel, double width_factor) {
  window_level_ = palp::view::adjust_window(window_level_, dlevel, width_factor);
  apply_preset();
}

}  // namespace palp::view
