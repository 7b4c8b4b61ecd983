// palpview's VTK scene: the volume palpd sent (GPU ray casting through one composed render
// scalar, transfer_presets.hpp; the skin preset's from d_surf, skin_surface.hpp), the tool
// (fingertip, two fingertips or probe), its contact points coloured by contact, the proxies and
// their springs, the device force as an arrow, the fingertip's spherical shadow on the skin, the
// skin deformation (SkinDeformer), and a head-up display (text, banner, force chart). It draws
// into any vtkRenderWindow: the GLFW-hosted vtkGenericOpenGLRenderWindow of palpview, or an
// off-screen window in the tests.
//
// Data flow per frame (main loop, palpview_main.cpp):
//   StreamClient::latest() -> update_state(): on a new volume, compose the render scalar into the
//     buffer the mapper renders and make a SkinDeformer over it; tool pose, contacts, proxies,
//     springs, arrow, shadow, HUD text and chart from the frame        ("receive" time)
//   -> update_deformation(): SkinDeformer::update writes the ROI of the same buffer in place,
//     and notes the box it wrote                                      ("deformation" time)
//   -> upload_deformation(): that box to the 3D texture (glTexSubImage3D) ("upload" time)
//   -> render(): the window's Render()                                   ("render" time)
// The HUD strings come from the pure functions hud_text / banner_text / force_text (hud_text.hpp,
// included here) so they are testable without a display.
//
// The parts, each in its own file here: volume_layer (volume, transfer functions, deformed
// texture), tool_layer (tool, contacts, proxies, springs, arrow), shadow (the fingertip's
// shadow), hud_layer (the HUD's text actors), force_chart (the chart and its renderer),
// orientation_marker (the patient-axes cube), structure_layer (vessels, artery and organs with
// their legend, the vessels preset's); patient_view places the camera in patient terms.
// This class composes them, owns the scene renderer and its camera.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "base/patient_frame.hpp"
#include "base/vec.hpp"
#include "deform/skin_deformation.hpp"
#include "render/hud_text.hpp"
#include "render/transfer_presets.hpp"
#include "stream/stream_client.hpp"

class vtkRenderWindow;

namespace palp::view {

struct CameraAxes;

struct SceneSettings {
  PresetId preset = PresetId::Skin;
  bool deformation = true;
  // Camera about the volume's centre, from the patient's `view` side (patient_view.hpp: through
  // the scene's direction matrix, whatever the voxel order), then turned by azimuth (about the
  // view's up) and elevation; distance in mm, 0 = fit the volume.
  Anatomy view = Anatomy::Anterior;
  double camera_azimuth_deg = 0, camera_elevation_deg = 0, camera_distance_mm = 0;
  // Framing on the tool: with follow_mm > 0 the camera looks at the device point from `view`
  // turned by azimuth and elevation, at the distance that shows follow_mm of anatomy across
  // the view's height, and follows the tool smoothly (the user's orbit and zoom are kept);
  // 0: the camera stays on the volume's centre (the whole volume fitted unless a distance).
  double follow_mm = 0;
  bool keep_outside = false;  // the CT outside the body mask shown (else transparent air)
  // The skin preset on the CT's HU as before (3 mm terraces on a 3 mm CT; the maps'
  // pseudo-density without the CT); false: on d_surf's zero level, the sub-voxel skin
  // (skin_surface.hpp).
  bool skin_from_volume = false;
  bool orientation_marker = true;  // the patient-axes cube in the bottom-left corner
  double arrow_mm_per_newton = 4.0;
  double chart_seconds = 5.0;  // force plot span
  bool overlays = true;        // HUD text, banner and chart
  bool tool_glyphs = true;     // tool, contacts, proxies, springs, arrow, shadow
  // The landmarks (L) wanted from the start; drawn only when palpd sends them and allows it
  // (landmark_layer.hpp: never to the trainee's controller while a task runs).
  bool show_landmarks = false;
  DeformerParams deformer;
};

// An RGB image read back from a window (row 0 at the bottom, as OpenGL reads it).
struct RgbImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  // width * height * 3
};

class RenderScene {
 public:
  // Adds its renderers to `window` (kept by reference count).
  RenderScene(vtkRenderWindow* window, SceneSettings settings);
  ~RenderScene();
  RenderScene(const RenderScene&) = delete;
  RenderScene& operator=(const RenderScene&) = delete;

  // Applies the newest stream state (see the data flow above). `inputs.preset`/`window` are
  // ignored (the scene's own are shown).
  void update_state(const LatestState& state, const HudInputs& inputs);
  // Runs the skin deformation for the contacts of the last state (no-op when disabled or no
  // volume). Returns what SkinDeformer reported.
  DeformResult update_deformation();
  // The contacts the last update_deformation() used (volume frame, mm).
  std::span<const DeformContact> deform_contacts() const;
  // Sends the box the deformation wrote to the volume texture (a sub-volume upload; the whole
  // volume only for a new one): the bytes sent this frame ("upload" time).
  std::int64_t upload_deformation();
  void render();  // uploads first when upload_deformation() was not called
  // Bytes the last upload_deformation() and render() sent to the volume texture.
  std::int64_t last_upload_bytes() const { return last_upload_bytes_; }

  bool has_volume() const;
  // Camera control (observer mouse).
  void orbit(double azimuth_deg, double elevation_deg);
  void zoom(double factor);
  void reset_camera();
  // Places the camera on the patient's `from` side (azimuth and elevation of the settings kept).
  void set_view(Anatomy from);
  Anatomy view() const;
  // The view the camera shows now ("anterior", "anterior-left", ...) and the CT's stored
  // orientation code ("LPS", "RAS", ...).
  std::string view_name() const;
  std::string orientation_code() const;
  CameraAxes camera_axes() const;

  void set_preset(PresetId id);  // resets the window to the preset's default
  PresetId preset() const;
  void adjust_window(double dlevel, double width_factor);
  Window window() const;

  void set_tool_glyphs_visible(bool visible);
  // The landmarks (L): drawn when wanted and palpd allows it (landmark_layer.hpp).
  void set_landmarks_wanted(bool wanted);
  bool landmarks_wanted() const;
  bool landmarks_visible() const;
  void set_overlays_visible(bool visible);

  // Display coordinates (pixels, origin bottom left) of a scene point.
  std::array<double, 2> to_display(const Vec3d& point) const;
  const std::string& last_hud_text() const;
  const std::string& last_banner_text() const;
  // Whether the registered device's workspace box is drawn (a device placed on the patient).
  bool workspace_visible() const;
  // Whether the scene's structures are drawn (the vessels preset, a volume with labels), and
  // the legend's lines (structure_layer.hpp; empty without structures).
  bool structures_visible() const;
  const std::vector<std::string>& legend_lines() const;
  // The render scalars currently in the mapper's buffer (deformed when pressing).
  const std::vector<float>& render_scalars() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::int64_t last_upload_bytes_ = 0;
  bool upload_called_ = false;
};

// Reads the window's last rendered frame back (RGB).
RgbImage capture_rgb(vtkRenderWindow* window);
// Writes the window's last rendered frame as a PNG (ResourceError when it cannot be written).
void write_png(vtkRenderWindow* window, const std::string& path);

}  // namespace palp::view
