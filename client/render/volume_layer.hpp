// The volume layer: the ray-cast CT volume, its transfer functions and its deformed texture.
//
// The volume palpd sent is GPU ray cast through one composed render scalar (transfer_presets.hpp):
// the CT's HU (or the maps' pseudo-density without the CT) for every preset but skin, which takes
// the sub-voxel skin from d_surf (skin_surface.hpp) unless set_skin_from_volume(true). A preset
// change that changes the scalar composes it again (and the deformer over it).
//
// The ray caster's sample distance is fixed (half the smallest voxel spacing) and its automatic
// adjustment off, so equal inputs give equal images. The deformation writes into
// render_scalars_, which the vtkFloatArray wraps without a copy (SetArray with save = 1);
// Modified() on the array makes the mapper re-upload the texture.
#pragma once

#include <vtkColorTransferFunction.h>
#include <vtkFloatArray.h>
#include <vtkGPUVolumeRayCastMapper.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPiecewiseFunction.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkVolume.h>
#include <vtkVolumeProperty.h>

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "deform/skin_deformation.hpp"
#include "render/skin_surface.hpp"
#include "render/transfer_presets.hpp"
#include "stream/stream_client.hpp"

namespace palp::view {

class VolumeLayer {
 public:
  // Adds the (hidden until a volume arrives) volume to `renderer`. `deformation` false: no
  // SkinDeformer, the volume stays undeformed.
  VolumeLayer(vtkRenderer* renderer, PresetId preset, bool deformation,
              const DeformerParams& deformer);

  // True when `state` brings a volume other than the one shown (a new one, or a new connection).
  bool is_new(const LatestState& state) const;
  // Takes `state`'s volume as the source: composes the render scalar into the mapper's buffer
  // and makes a SkinDeformer over it. False (nothing built, though it is the source now) when
  // the volume's maps do not match its dimensions.
  bool load(const LatestState& state);
  // The volume last taken (null before the first).
  const RenderVolume* source() const { return source_.get(); }

  // The in-contact contacts of `frame` (none when it is not valid), for the next deform().
  void set_contacts(const FrameState& frame);
  // Runs SkinDeformer over the buffer (no-op when disabled or no volume) and notes the box it
  // wrote for upload(). Returns what SkinDeformer reported.
  DeformResult deform();
  // The contacts deform() uses (volume frame, mm).
  std::span<const DeformContact> deform_contacts() const { return deform_contacts_; }
  // Sends what changed to the GPU before the next render: the box deform() wrote, as a
  // sub-volume of the existing 3D texture (glTexSubImage3D), so the bytes are bounded by the
  // box, not the volume. Where the texture is not there yet (a new volume: the render uploads
  // all of it) or cannot be reached, the whole volume is marked for re-upload instead. Needs
  // the render window's context current. Returns the bytes sent (or marked) for this frame.
  std::int64_t upload(vtkRenderWindow* window);
  std::int64_t full_uploads() const { return full_uploads_; }  // whole-volume fallbacks so far
  // The render scalars in the mapper's buffer (deformed when pressing).
  const std::vector<float>& render_scalars() const { return render_scalars_; }

  void set_preset(PresetId id);  // resets the window to the preset's default
  // Whether the CT's HU outside the body mask (table, cables, air) are shown; from the next load.
  void set_keep_outside(bool keep) { keep_outside_ = keep; }
  // The skin preset on the volume's own scalar (the CT's HU, as before the sub-voxel skin)
  // instead of d_surf's zero level; from the next load or preset change.
  void set_skin_from_volume(bool from_volume) { skin_from_volume_ = from_volume; }
  ScalarKind scalar_kind() const { return kind_; }
  bool ct() const { return ct_; }
  const Preset& preset() const { return preset_; }
  void adjust_window(double dlevel, double width_factor);
  Window window() const { return window_level_; }

 private:
  void apply_preset();
  // Composes the render scalar of kind_ from source_ into the mapper's buffer, hands it to the
  // mapper whole and makes the deformer over it.
  void compose();

  bool deformation_;
  DeformerParams deformer_params_;
  std::shared_ptr<const RenderVolume> source_;  // the volume the image was built from
  std::shared_ptr<const RenderVolume> seen_;    // the last volume offered (kept or refused)
  std::uint64_t connection_ = 0;
  std::vector<float> render_scalars_;  // the mapper's buffer
  vtkNew<vtkImageData> image_;
  vtkNew<vtkFloatArray> scalar_array_;
  vtkNew<vtkGPUVolumeRayCastMapper> mapper_;
  vtkNew<vtkVolumeProperty> property_;
  vtkNew<vtkColorTransferFunction> colour_;
  vtkNew<vtkPiecewiseFunction> opacity_;
  vtkNew<vtkVolume> volume_;
  Preset preset_;
  Window window_level_;
  std::unique_ptr<SkinDeformer> deformer_;
  std::vector<DeformContact> deform_contacts_;
  bool deform_was_active_ = false;
  std::array<std::int64_t, 3> pending_lo_{}, pending_hi_{};  // box written, not yet uploaded
  bool loaded_ = false;  // a new volume: the next render uploads it whole
  std::int64_t full_uploads_ = 0;
  bool ct_ = false;                     // the scalar is the CT's HU (else the maps' pseudo-density)
  bool keep_outside_ = false;           // HU outside the body mask kept (else made air)
  bool skin_from_volume_ = false;       // the skin preset on the HU (else on d_surf's zero level)
  ScalarKind kind_ = ScalarKind::Maps;  // what render_scalars_ holds
};

}  // namespace palp::view
