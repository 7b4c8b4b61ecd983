// palpview's VTK scene: composes its parts, owns the scene renderer and camera, reads frames back.
//
// See render_scene.hpp for what it draws and the per-frame data flow.
//
// The parts add their props to the scene renderer in a fixed order (volume, tool layer, HUD text;
// shadow rings as the tools need them), the chart has its own renderer drawn over it (layer 1).
#include "render/render_scene.hpp"

#include <vtkCamera.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPNGWriter.h>
#include <vtkPointData.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowToImageFilter.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>

#include "base/errors.hpp"
#include "render/force_chart.hpp"
#include "render/hud_layer.hpp"
#include "render/landmark_layer.hpp"
#include "render/orientation_marker.hpp"
#include "render/patient_view.hpp"
#include "render/shadow.hpp"
#include "render/structure_layer.hpp"
#include "render/tool_layer.hpp"
#include "render/volume_layer.hpp"
#include "render/workspace_box.hpp"
#include "window/controller_input.hpp"

namespace palp::view {

// ------------------------------------------------------------------------------ the scene

struct RenderScene::Impl {
  vtkSmartPointer<vtkRenderWindow> window;
  SceneSettings settings;
  vtkNew<vtkRenderer> renderer;  // declared before the parts: it outlives them
  // The parts, constructed in this order (the order their props enter the renderer).
  VolumeLayer volume;
  StructureLayer structures;  // over the volume, with the vessels preset
  ToolLayer tools;
  FingertipShadow shadow;
  HudLayer hud;
  ForceChart chart;
  OrientationMarker marker;
  WorkspaceBox workspace;
  LandmarkLayer landmarks{renderer};
  bool landmarks_wanted = false;
  PatientFrame frame;  // of the current scene (its direction matrix)
  std::string orientation = "LPS";
  const SceneDescription* framed_scene = nullptr;
  bool camera_placed = false;
  bool tool_known = false;  // follow: the smoothed device point below is valid
  Vec3d tool_focus{};       // follow: the smoothed device point the camera looks at
  Vec3d tool_axis{};        // follow: the tool's +z when it was first seen (scene frame)
  std::uint64_t followed_connection = 0;
  bool tool_glyphs = true;
  bool overlays = true;

  Impl(vtkRenderWindow* w, const SceneSettings& s)
      : window(w),
        settings(s),
        volume(renderer, s.preset, s.deformation, s.deformer),
        structures(renderer),
        tools(renderer, s.arrow_mm_per_newton),
        shadow(renderer),
        hud(renderer),
        chart(s.chart_seconds),
        workspace(renderer),
        landmarks_wanted(s.show_landmarks),
        tool_glyphs(s.tool_glyphs),
        overlays(s.overlays) {}

  void place_camera();
  void follow_tool(const FrameState& latest);
  void apply_visibility();
};

RenderScene::RenderScene(vtkRenderWindow* window, SceneSettings settings)
    : impl_(std::make_unique<Impl>(window, settings)) {
  Impl& s = *impl_;
  s.volume.set_keep_outside(settings.keep_outside);
  s.volume.set_skin_from_volume(settings.skin_from_volume);
  s.renderer->SetBackground(0.08, 0.09, 0.12);
  s.renderer->SetLayer(0);
  // The semi-transparent tool (tool_layer.cpp) sorted against the ray-cast volume: depth
  // peeling with volumes, so the hand inside the skin is seen through it, not pasted over it.
  s.renderer->SetUseDepthPeeling(1);
  s.renderer->SetUseDepthPeelingForVolumes(true);
  s.renderer->SetMaximumNumberOfPeels(4);
  s.renderer->SetOcclusionRatio(0.0);
  window->SetAlphaBitPlanes(1);
  window->SetMultiSamples(0);
  window->SetNumberOfLayers(2);
  window->AddRenderer(s.renderer);
  window->AddRenderer(s.chart.renderer());
  window->AddRenderer(s.marker.renderer());
  s.apply_visibility();
}

RenderScene::~RenderScene() {
  if (impl_ && impl_->window) {
    impl_->window->RemoveRenderer(impl_->renderer);
    impl_->window->RemoveRenderer(impl_->chart.renderer());
    impl_->window->RemoveRenderer(impl_->marker.renderer());
  }
}

void RenderScene::Impl::place_camera() {
  double bounds[6] = {0, 1, 0, 1, 0, 1};
  if (const RenderVolume* source = volume.source()) {
    for (int a = 0; a < 3; ++a) {
      bounds[2 * a] = source->origin[a];
      bounds[2 * a + 1] =
          source->origin[a] + static_cast<double>(source->dims[a] - 1) * source->spacing[a];
    }
  }
  const bool follow = settings.follow_mm > 0 && tool_known;
  const Vec3d centre = follow ? tool_focus
                              : Vec3d{0.5 * (bounds[0] + bounds[1]), 0.5 * (bounds[2] + bounds[3]),
                                      0.5 * (bounds[4] + bounds[5])};
  const double radius =
      0.5 * std::sqrt(std::pow(bounds[1] - bounds[0], 2) + std::pow(bounds[3] - bounds[2], 2) +
                      std::pow(bounds[5] - bounds[4], 2));
  vtkCamera* camera = renderer->GetActiveCamera();
  camera->SetViewAngle(30.0);
  // Following: follow_mm across the view's height (view angle 30 degrees).
  const double distance = settings.camera_distance_mm > 0 ? settings.camera_distance_mm
                          : follow ? 0.5 * settings.follow_mm / std::tan(std::numbers::pi / 12.0)
                                   : std::max(radius, 1.0) / std::sin(std::numbers::pi / 12.0);
  // From the patient's side (anterior by default), head up; then azimuth and elevation.
  CameraPlacement c = patient_view(frame, settings.view, centre, distance);
  if (follow) {
    // Oblique on the contact: between the view's side and the tool's axis (its +z leaves the
    // skin), a little from above the patient's head; the view's up kept.
    const Vec3d side = (c.position - centre) * (1.0 / distance);
    Vec3d dir = side + tool_axis + 0.4 * c.up;
    const double n = norm(dir);
    dir = n > 1e-6 ? dir * (1.0 / n) : side;
    c.position = centre + dir * distance;
  }
  camera->SetFocalPoint(c.focal.x, c.focal.y, c.focal.z);
  camera->SetPosition(c.position.x, c.position.y, c.position.z);
  camera->SetViewUp(c.up.x, c.up.y, c.up.z);
  camera->Azimuth(settings.camera_azimuth_deg);
  camera->Elevation(settings.camera_elevation_deg);
  camera->OrthogonalizeViewUp();
  renderer->ResetCameraClippingRange(bounds);
}

// The camera's focal point eases towards the device point (a quarter of the way a frame; a jump
// of more than 100 mm, a new tool or connection, is taken at once), the camera moving with it.
void RenderScene::Impl::follow_tool(const FrameState& latest) {
  if (settings.follow_mm <= 0 || !latest.valid) return;
  const Vec3d target = latest.pose.position;
  if (!std::isfinite(target.x) || !std::isfinite(target.y) || !std::isfinite(target.z)) return;
  if (!tool_known) {
    tool_known = true;
    tool_focus = target;
    tool_axis = rotate(latest.pose.orientation, Vec3d{0, 0, 1});
    if (camera_placed) place_camera();
    return;
  }
  const Vec3d gap = target - tool_focus;
  const Vec3d move = norm(gap) > 100.0 ? gap : gap * 0.25;
  tool_focus = tool_focus + move;
  vtkCamera* camera = renderer->GetActiveCamera();
  double f[3], p[3];
  camera->GetFocalPoint(f);
  camera->GetPosition(p);
  camera->SetFocalPoint(f[0] + move.x, f[1] + move.y, f[2] + move.z);
  camera->SetPosition(p[0] + move.x, p[1] + move.y, p[2] + move.z);
  renderer->ResetCameraClippingRange();
}

void RenderScene::Impl::apply_visibility() {
  structures.set_visible(volume.preset().id == PresetId::Vessels, overlays);
  hud.set_visible(overlays);
  chart.set_visible(overlays);
  marker.set_visible(overlays && settings.orientation_marker);
}

void RenderScene::update_state(const LatestState& state, const HudInputs& inputs) {
  Impl& s = *impl_;
  if (state.scene && state.scene.get() != s.framed_scene) {  // a new scene: its patient frame
    s.framed_scene = state.scene.get();
    WorldPlacement world;
    world.origin = state.scene->origin;
    world.direction = state.scene->direction;
    s.frame = patient_frame(world);
    s.orientation = s.frame.orientation_code();
    s.marker.set_frame(s.frame);
  }
  if (s.volume.is_new(state) && s.volume.load(state)) {
    s.structures.load(*s.volume.source(), state.scene.get());
    if (!s.camera_placed) {
      s.place_camera();
      s.camera_placed = true;
    }
  }
  // A palpd that says nothing of the pulse (older): the artery steady, at its systolic colour.
  s.structures.set_pulse(state.frame.pulse_bpm ? state.frame.pulse_wave : 1.0,
                         state.frame.pulse_bpm);
  if (state.connection != s.followed_connection) {  // a new connection: find the tool anew
    s.followed_connection = state.connection;
    s.tool_known = false;
  }
  s.follow_tool(state.frame);
  s.tools.update(state, s.tool_glyphs);
  s.workspace.update(state.scene.get(), state.link.registration_home, s.tool_glyphs);
  s.shadow.update(state.frame, s.tools.tool_name(), s.volume.source(), s.tool_glyphs);
  s.volume.set_contacts(state.frame);  // for the deformation step
  s.landmarks.update(state, s.landmarks_wanted);

  if (s.overlays) {
    HudInputs shown = inputs;
    shown.preset = s.volume.preset().id;
    shown.window = s.volume.window();
    shown.deformation = s.settings.deformation;
    double dop[3];
    s.renderer->GetActiveCamera()->GetDirectionOfProjection(dop);
    shown.view = palp::view::view_name(s.frame, {dop[0], dop[1], dop[2]});
    shown.orientation = s.orientation;
    s.hud.update(state, shown);
    s.chart.update(state.force_history);
  }
  s.apply_visibility();
}

DeformResult RenderScene::update_deformation() {
  return impl_->volume.deform();
}

std::span<const DeformContact> RenderScene::deform_contacts() const {
  return impl_->volume.deform_contacts();
}

std::int64_t RenderScene::upload_deformation() {
  last_upload_bytes_ = impl_->volume.upload(impl_->window);
  upload_called_ = true;
  return last_upload_bytes_;
}

void RenderScene::render() {
  const std::int64_t bytes = impl_->volume.upload(impl_->window);  // 0 once uploaded
  last_upload_bytes_ = upload_called_ ? last_upload_bytes_ + bytes : bytes;
  upload_called_ = false;
  impl_->marker.follow(impl_->renderer->GetActiveCamera());
  impl_->window->Render();
}

bool RenderScene::has_volume() const {
  return impl_->volume.source() != nullptr;
}

void RenderScene::orbit(double azimuth_deg, double elevation_deg) {
  vtkCamera* camera = impl_->renderer->GetActiveCamera();
  camera->Azimuth(azimuth_deg);
  camera->Elevation(elevation_deg);
  camera->OrthogonalizeViewUp();
  impl_->renderer->ResetCameraClippingRange();
}

void RenderScene::zoom(double factor) {
  if (factor > 0) impl_->renderer->GetActiveCamera()->Dolly(factor);
  impl_->renderer->ResetCameraClippingRange();
}

void RenderScene::reset_camera() {
  impl_->place_camera();
}

void RenderScene::set_view(Anatomy from) {
  impl_->settings.view = from;
  impl_->place_camera();
}

Anatomy RenderScene::view() const {
  return impl_->settings.view;
}

std::string RenderScene::view_name() const {
  double dop[3];
  impl_->renderer->GetActiveCamera()->GetDirectionOfProjection(dop);
  return palp::view::view_name(impl_->frame, {dop[0], dop[1], dop[2]});
}

std::string RenderScene::orientation_code() const {
  return impl_->orientation;
}

CameraAxes RenderScene::camera_axes() const {
  vtkCamera* camera = impl_->renderer->GetActiveCamera();
  double up[3], forward[3];
  camera->GetViewUp(up);
  camera->GetDirectionOfProjection(forward);
  const Vec3d u{up[0], up[1], up[2]}, f{forward[0], forward[1], forward[2]};
  Vec3d r = cross(f, u);
  const double n = norm(r);
  if (n > 0) r = r * (1.0 / n);
  return {r, u};
}

void RenderScene::set_preset(PresetId id) {
  impl_->volume.set_preset(id);
  impl_->apply_visibility();
}

PresetId RenderScene::preset() const {
  return impl_->volume.preset().id;
}

void RenderScene::adjust_window(double dlevel, double width_factor) {
  impl_->volume.adjust_window(dlevel, width_factor);
}

Window RenderScene::window() const {
  return impl_->volume.window();
}

void RenderScene::set_landmarks_wanted(bool wanted) {
  impl_->landmarks_wanted = wanted;
}
bool RenderScene::landmarks_wanted() const {
  return impl_->landmarks_wanted;
}
bool RenderScene::landmarks_visible() const {
  return impl_->landmarks.visible();
}

void RenderScene::set_tool_glyphs_visible(bool visible) {
  impl_->tool_glyphs = visible;
  if (!visible) {
    impl_->tools.hide();
    impl_->shadow.hide();
  }
}

void RenderScene::set_overlays_visible(bool visible) {
  impl_->overlays = visible;
  impl_->apply_visibility();
}

std::array<double, 2> RenderScene::to_display(const Vec3d& point) const {
  vtkRenderer* r = impl_->renderer;
  r->SetWorldPoint(point.x, point.y, point.z, 1.0);
  r->WorldToDisplay();
  double d[3];
  r->GetDisplayPoint(d);
  return {d[0], d[1]};
}

const std::string& RenderScene::last_hud_text() const {
  return impl_->hud.hud_string();
}
const std::string& RenderScene::last_banner_text() const {
  return impl_->hud.banner_string();
}
bool RenderScene::workspace_visible() const {
  return impl_->workspace.visible();
}
bool RenderScene::structures_visible() const {
  return impl_->structures.visible() && impl_->structures.has_structures();
}
const std::vector<std::string>& RenderScene::legend_lines() const {
  return impl_->structures.legend();
}

const std::vector<float>& RenderScene::render_scalars() const {
  return impl_->volume.render_scalars();
}

// ------------------------------------------------------------------------------ read back

RgbImage capture_rgb(vtkRenderWindow* window) {
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();
  grab->ShouldRerenderOff();
  grab->Update();
  vtkImageData* image = grab->GetOutput();
  int dims[3] = {0, 0, 0};
  image->GetDimensions(dims);
  RgbImage out;
  out.width = dims[0];
  out.height = dims[1];
  auto* pixels = vtkUnsignedCharArray::SafeDownCast(image->GetPointData()->GetScalars());
  if (!pixels) return out;
  const auto n = static_cast<std::size_t>(out.width) * static_cast<std::size_t>(out.height) * 3;
  if (static_cast<std::size_t>(pixels->GetNumberOfValues()) < n) return out;
  out.rgb.assign(pixels->GetPointer(0), pixels->GetPointer(0) + n);
  return out;
}

void write_png(vtkRenderWindow* window, const std::string& path) {
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();
  grab->ShouldRerenderOff();
  grab->Update();
  const std::string temporary = path + ".tmp.png";
  vtkNew<vtkPNGWriter> writer;
  writer->SetFileName(temporary.c_str());
  writer->SetInputConnection(grab->GetOutputPort());
  writer->Write();
  std::error_code error;
  if (writer->GetErrorCode() != 0 || !std::filesystem::exists(temporary, error))
    throw ResourceError("cannot write the screenshot " + path);
  std::filesystem::rename(temporary, path, error);
  if (error) throw ResourceError("cannot write the screenshot " + path + ": " + error.message());
}

}  // namespace palp::view
