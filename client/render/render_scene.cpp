// palpview's VTK scene (see render_scene.hpp for what it draws and the per-frame data flow).
//
// Choices:
//   - The tool, contacts and shadow are opaque geometry: VTK composites volumes over
//     translucent geometry regardless of depth, so only opaque geometry (which writes the depth
//     buffer the ray caster stops at) shows correctly in front of or inside the skin.
//   - The ray caster's sample distance is fixed (half the smallest voxel spacing) and its
//     automatic adjustment off, so equal inputs give equal images.
//   - The deformation writes into render_scalars_, which the vtkFloatArray wraps without a copy
//     (SetArray with save = 1); Modified() on the array makes the mapper re-upload the texture.
#include "render/render_scene.hpp"

#include <vtkActor.h>
#include <vtkAppendPolyData.h>
#include <vtkArrowSource.h>
#include <vtkAxis.h>
#include <vtkBrush.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkChartXY.h>
#include <vtkColorTransferFunction.h>
#include <vtkContextActor.h>
#include <vtkContextScene.h>
#include <vtkCubeSource.h>
#include <vtkCylinderSource.h>
#include <vtkDiskSource.h>
#include <vtkFloatArray.h>
#include <vtkGPUVolumeRayCastMapper.h>
#include <vtkImageData.h>
#include <vtkMatrix4x4.h>
#include <vtkNew.h>
#include <vtkPNGWriter.h>
#include <vtkPiecewiseFunction.h>
#include <vtkPlot.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>
#include <vtkSphereSource.h>
#include <vtkTable.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkTransform.h>
#include <vtkTransformPolyDataFilter.h>
#include <vtkUnsignedCharArray.h>
#include <vtkVolume.h>
#include <vtkVolumeProperty.h>
#include <vtkWindowToImageFilter.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <sstream>

#include "base/errors.hpp"
#include "model/tool.hpp"
#include "window/controller_input.hpp"

namespace palp::view {

// ------------------------------------------------------------------------------ HUD text

namespace {

std::string fixed(double value, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, value);
  return buffer;
}

const char* link_label(LinkState state) {
  switch (state) {
    case LinkState::Connecting:
      return "connecting";
    case LinkState::Loading:
      return "loading";
    case LinkState::Live:
      return "live";
    case LinkState::Stalled:
      return "stalled";
    case LinkState::Reconnecting:
      return "reconnecting";
    case LinkState::Refused:
      return "refused";
  }
  return "?";
}

}  // namespace

std::string banner_text(const LatestState& state) {
  const LinkStats& link = state.link;
  std::vector<std::string> lines;
  const std::string why = link.message.empty() ? "" : " (" + link.message + ")";
  switch (link.state) {
    case LinkState::Connecting:
      lines.push_back("CONNECTING to palpd" + why);
      break;
    case LinkState::Loading:
      lines.push_back("LOADING scene " + fixed(100.0 * link.volume_progress, 0) + "%");
      break;
    case LinkState::Stalled:
      lines.push_back("STREAM STALLED: no frame for " + fixed(link.since_last_frame_s, 1) + " s");
      break;
    case LinkState::Reconnecting:
      lines.push_back("CONNECTION LOST: reconnecting" + why);
      break;
    case LinkState::Refused:
      lines.push_back("REFUSED by palpd" + why);
      break;
    case LinkState::Live:
      break;
  }
  if (state.frame.valid) {
    const std::string dev = link.device_message.empty() ? "" : " (" + link.device_message + ")";
    if (state.frame.device_state == DeviceState::Absent) lines.push_back("DEVICE ABSENT" + dev);
    if (state.frame.device_state == DeviceState::Fault)
      lines.push_back("DEVICE FAULT " + std::to_string(state.frame.fault) + dev);
  }
  if (link.server_paused) lines.push_back("PAUSED");
  std::string out;
  for (const std::string& line : lines) out += (out.empty() ? "" : "\n") + line;
  return out;
}

std::string force_text(const LatestState& state) {
  const Vec3d& f = state.frame.force;
  std::string out = "force " + fixed(norm(f), 2) + " N  (" + fixed(f.x, 2) + ", " + fixed(f.y, 2) +
                    ", " + fixed(f.z, 2) + ")";
  if (state.scene && !state.scene->device_renders_force)
    out += "  -- force not rendered by the device";
  return out;
}

std::string hud_text(const LatestState& state, const HudInputs& inputs) {
  const LinkStats& link = state.link;
  std::ostringstream out;
  out << (inputs.controller ? "controller" : "observer") << "  link " << link_label(link.state);
  if (link.connections > 1) out << " (reconnected " << link.connections - 1 << "x)";
  out << "\n";
  out << "view " << fixed(inputs.view_fps, 1) << " fps   stream " << fixed(link.frames_per_s, 0)
      << " frames/s\n";
  out << "latency "
      << (link.latency_ms >= 0 ? fixed(link.latency_ms, 1) + " ms" : std::string("n/a"))
      << "   delivered "
      << (link.delivered >= 0 ? fixed(100.0 * link.delivered, 1) + "%" : std::string("n/a"))
      << "\n";
  out << "tick rate " << fixed(link.server_tick_rate_hz, 0) << " Hz";
  if (link.server_overruns > 0) out << "   overruns " << link.server_overruns;
  out << "\n";
  if (state.scene) {
    out << "tool " << state.scene->tool << "   device " << state.scene->device << "\n";
  }
  out << "contacts " << state.frame.n_contact << "/" << state.frame.contact_points;
  out << "   deformation " << (inputs.deformation ? "on" : "off") << "\n";
  out << "preset " << to_string(inputs.preset) << "  level " << fixed(inputs.window.level, 0)
      << " width " << fixed(inputs.window.width, 0);
  return out.str();
}

// ------------------------------------------------------------------------------ helpers

namespace {

// The 4x4 matrix of a pose (tool frame -> scene frame).
vtkSmartPointer<vtkMatrix4x4> pose_matrix(const Pose& pose) {
  auto m = vtkSmartPointer<vtkMatrix4x4>::New();
  const Quat q = normalized(pose.orientation);
  const Quat r = std::isfinite(q.w) ? q : Quat{};
  const Vec3d axes[3] = {rotate(r, {1, 0, 0}), rotate(r, {0, 1, 0}), rotate(r, {0, 0, 1})};
  for (int c = 0; c < 3; ++c) {
    m->SetElement(0, c, axes[c].x);
    m->SetElement(1, c, axes[c].y);
    m->SetElement(2, c, axes[c].z);
  }
  m->SetElement(0, 3, pose.position.x);
  m->SetElement(1, 3, pose.position.y);
  m->SetElement(2, 3, pose.position.z);
  return m;
}

// A matrix mapping +x (arrow) or +z (disk) to `direction`, scaled, at `origin`.
vtkSmartPointer<vtkMatrix4x4> frame_matrix(const Vec3d& origin, Vec3d direction, int along_axis,
                                           const Vec3d& scale) {
  const double n = norm(direction);
  direction = n > 0 ? direction * (1.0 / n) : Vec3d{0, 0, 1};
  const Vec3d helper = std::abs(direction.x) < 0.9 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
  Vec3d a = cross(direction, helper);
  a = a * (1.0 / norm(a));
  const Vec3d b = cross(direction, a);
  Vec3d cols[3];
  if (along_axis == 0) {
    cols[0] = direction, cols[1] = a, cols[2] = b;
  } else {
    cols[0] = a, cols[1] = b, cols[2] = direction;
  }
  const double s[3] = {scale.x, scale.y, scale.z};
  auto m = vtkSmartPointer<vtkMatrix4x4>::New();
  for (int c = 0; c < 3; ++c) {
    m->SetElement(0, c, cols[c].x * s[c]);
    m->SetElement(1, c, cols[c].y * s[c]);
    m->SetElement(2, c, cols[c].z * s[c]);
  }
  m->SetElement(0, 3, origin.x);
  m->SetElement(1, 3, origin.y);
  m->SetElement(2, 3, origin.z);
  return m;
}

vtkSmartPointer<vtkPolyData> transformed(vtkPolyDataAlgorithm* source, vtkTransform* transform) {
  vtkNew<vtkTransformPolyDataFilter> filter;
  filter->SetInputConnection(source->GetOutputPort());
  filter->SetTransform(transform);
  filter->Update();
  auto out = vtkSmartPointer<vtkPolyData>::New();
  out->DeepCopy(filter->GetOutput());
  return out;
}

// A fingertip in the tool frame: a ball of radius 8 at the device point (its bottom touches the
// pad plane z = -8) and the finger going up +z.
void add_fingertip(vtkAppendPolyData* append, double cx) {
  vtkNew<vtkSphereSource> tip;
  tip->SetRadius(-kFingerPadZ);
  tip->SetCenter(cx, 0, 0);
  tip->SetThetaResolution(24);
  tip->SetPhiResolution(16);
  tip->Update();
  append->AddInputData(tip->GetOutput());
  vtkNew<vtkCylinderSource> finger;  // along +y, centred: turned to +z, from z = 0 to 60
  finger->SetRadius(-kFingerPadZ);
  finger->SetHeight(60.0);
  finger->SetResolution(24);
  finger->CappingOn();
  vtkNew<vtkTransform> t;
  t->Translate(cx, 0, 30.0);
  t->RotateX(90.0);
  append->AddInputData(transformed(finger, t));
}

vtkSmartPointer<vtkPolyData> tool_geometry(const std::string& tool_name) {
  vtkNew<vtkAppendPolyData> append;
  Tool tool;
  try {
    tool = parse_tool(tool_name);
  } catch (const Error&) {
    tool = parse_tool("finger:37");
  }
  if (tool.kind == ToolKind::Probe) {
    vtkNew<vtkCubeSource> face;  // the probe head, face at z = -50
    face->SetXLength(2 * kProbeHalfX + 4);
    face->SetYLength(2 * kProbeHalfY + 2);
    face->SetZLength(-kProbeFaceZ);
    face->SetCenter(0, 0, 0.5 * kProbeFaceZ);
    face->Update();
    append->AddInputData(face->GetOutput());
    vtkNew<vtkCubeSource> handle;
    handle->SetXLength(24);
    handle->SetYLength(10);
    handle->SetZLength(60);
    handle->SetCenter(0, 0, 30);
    handle->Update();
    append->AddInputData(handle->GetOutput());
  } else if (tool.kind == ToolKind::TwoFinger) {
    add_fingertip(append, -kTwoFingerPadX);
    add_fingertip(append, kTwoFingerPadX);
  } else {
    add_fingertip(append, 0.0);
  }
  append->Update();
  auto out = vtkSmartPointer<vtkPolyData>::New();
  out->DeepCopy(append->GetOutput());
  return out;
}

// Pad centres (tool frame) of the fingertips, for the shadow; none for the probe.
std::vector<Vec3d> pad_centres(const std::string& tool_name) {
  try {
    const Tool tool = parse_tool(tool_name);
    if (tool.kind == ToolKind::Finger) return {{0, 0, kFingerPadZ}};
    if (tool.kind == ToolKind::TwoFinger)
      return {{-kTwoFingerPadX, 0, kFingerPadZ}, {kTwoFingerPadX, 0, kFingerPadZ}};
  } catch (const Error&) {
  }
  return {};
}

double pad_radius(const std::string& tool_name) {
  try {
    const Tool tool = parse_tool(tool_name);
    const int rings = tool.per_pad >= 37 ? 3 : tool.per_pad >= 19 ? 2 : tool.per_pad >= 7 ? 1 : 0;
    return kFingerRingPitch * rings + 2.0;
  } catch (const Error&) {
    return 8.0;
  }
}

// Trilinear sample of a float map on the render grid (scene frame mm); `outside` beyond it.
double sample(const RenderVolume& volume, const std::vector<float>& map, const Vec3d& p,
              double outside) {
  const double g[3] = {p.x / volume.spacing[0], p.y / volume.spacing[1], p.z / volume.spacing[2]};
  std::int64_t i0[3];
  double f[3];
  for (int a = 0; a < 3; ++a) {
    if (!(g[a] >= 0) || g[a] > static_cast<double>(volume.dims[a] - 1)) return outside;
    i0[a] = std::min<std::int64_t>(static_cast<std::int64_t>(g[a]), volume.dims[a] - 2);
    if (i0[a] < 0) return outside;
    f[a] = g[a] - static_cast<double>(i0[a]);
  }
  const auto at = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return static_cast<double>(
        map[static_cast<std::size_t>((k * volume.dims[1] + j) * volume.dims[0] + i)]);
  };
  double v = 0;
  for (int c = 0; c < 8; ++c) {
    const int di = c & 1, dj = (c >> 1) & 1, dk = (c >> 2) & 1;
    const double w = (di ? f[0] : 1 - f[0]) * (dj ? f[1] : 1 - f[1]) * (dk ? f[2] : 1 - f[2]);
    v += w * at(i0[0] + di, i0[1] + dj, i0[2] + dk);
  }
  return v;
}

// Points as vertices with per-point colours.
void set_points(vtkPolyData* poly, const std::vector<Vec3d>& points,
                const std::vector<std::array<unsigned char, 3>>& colours) {
  vtkNew<vtkPoints> pts;
  vtkNew<vtkCellArray> verts;
  vtkNew<vtkUnsignedCharArray> rgb;
  rgb->SetNumberOfComponents(3);
  rgb->SetName("colour");
  for (std::size_t n = 0; n < points.size(); ++n) {
    const vtkIdType id = pts->InsertNextPoint(points[n].x, points[n].y, points[n].z);
    verts->InsertNextCell(1, &id);
    rgb->InsertNextTypedTuple(colours[n].data());
  }
  poly->SetPoints(pts);
  poly->SetVerts(verts);
  poly->GetPointData()->SetScalars(rgb);
}

void set_lines(vtkPolyData* poly, const std::vector<std::pair<Vec3d, Vec3d>>& segments) {
  vtkNew<vtkPoints> pts;
  vtkNew<vtkCellArray> lines;
  for (const auto& [a, b] : segments) {
    const vtkIdType ids[2] = {pts->InsertNextPoint(a.x, a.y, a.z),
                              pts->InsertNextPoint(b.x, b.y, b.z)};
    lines->InsertNextCell(2, ids);
  }
  poly->SetPoints(pts);
  poly->SetLines(lines);
}

vtkSmartPointer<vtkActor> make_actor(vtkPolyData* poly, bool scalar_colours) {
  vtkNew<vtkPolyDataMapper> mapper;
  mapper->SetInputData(poly);
  mapper->SetScalarVisibility(scalar_colours);
  if (scalar_colours) mapper->SetColorModeToDirectScalars();
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  return actor;
}

}  // namespace

// ------------------------------------------------------------------------------ the scene

struct RenderScene::Impl {
  vtkSmartPointer<vtkRenderWindow> window;
  SceneSettings settings;
  vtkNew<vtkRenderer> renderer;
  vtkNew<vtkRenderer> chart_renderer;

  // Volume.
  std::shared_ptr<const RenderVolume> volume_source;  // the volume the image was built from
  std::uint64_t connection = 0;
  std::vector<float> render_scalars;  // the mapper's buffer
  vtkNew<vtkImageData> image;
  vtkNew<vtkFloatArray> scalar_array;
  vtkNew<vtkGPUVolumeRayCastMapper> mapper;
  vtkNew<vtkVolumeProperty> property;
  vtkNew<vtkColorTransferFunction> colour;
  vtkNew<vtkPiecewiseFunction> opacity;
  vtkNew<vtkVolume> volume;
  Preset preset;
  Window window_level;
  std::unique_ptr<SkinDeformer> deformer;
  std::vector<DeformContact> deform_contacts;
  bool deform_was_active = false;  // the last update wrote a ROI (the next one restores it)
  bool camera_placed = false;

  // Tool and contacts.
  std::string tool_name;
  std::shared_ptr<const SceneDescription> scene;
  vtkSmartPointer<vtkActor> tool_actor;
  vtkNew<vtkPolyData> contact_poly, proxy_poly, spring_poly;
  vtkSmartPointer<vtkActor> contact_actor, proxy_actor, spring_actor;
  vtkNew<vtkArrowSource> arrow_source;
  vtkSmartPointer<vtkActor> arrow_actor;
  vtkNew<vtkDiskSource> shadow_source;
  std::vector<vtkSmartPointer<vtkActor>> shadow_actors;
  bool tool_glyphs = true;

  // HUD.
  vtkNew<vtkTextActor> hud;
  vtkNew<vtkTextActor> banner;
  vtkNew<vtkTextActor> force_label;
  vtkNew<vtkContextActor> chart_actor;
  vtkNew<vtkContextScene> chart_scene;
  vtkNew<vtkChartXY> chart;
  vtkNew<vtkTable> chart_table;
  bool overlays = true;
  std::string hud_string, banner_string;

  void build_volume(const RenderVolume& source);
  void apply_preset();
  void place_camera();
  void update_tool(const LatestState& state);
  void update_shadow(const LatestState& state);
  void update_chart(const LatestState& state);
  void apply_visibility();
};

RenderScene::RenderScene(vtkRenderWindow* window, SceneSettings settings)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.window = window;
  s.settings = settings;
  s.tool_glyphs = settings.tool_glyphs;
  s.overlays = settings.overlays;
  s.preset = make_preset(settings.preset);
  s.window_level = s.preset.window;

  s.renderer->SetBackground(0.08, 0.09, 0.12);
  s.renderer->SetLayer(0);
  s.chart_renderer->SetLayer(1);
  s.chart_renderer->SetViewport(0.62, 0.0, 1.0, 0.3);
  s.chart_renderer->InteractiveOff();
  window->SetNumberOfLayers(2);
  window->AddRenderer(s.renderer);
  window->AddRenderer(s.chart_renderer);

  // Volume pipeline (its input arrives with the volume).
  s.mapper->AutoAdjustSampleDistancesOff();
  s.mapper->SetBlendModeToComposite();
  s.property->SetColor(s.colour);
  s.property->SetScalarOpacity(s.opacity);
  s.property->SetInterpolationTypeToLinear();
  s.property->SetAmbient(0.25);
  s.property->SetDiffuse(0.75);
  s.property->SetSpecular(0.15);
  s.property->SetSpecularPower(20.0);
  s.volume->SetMapper(s.mapper);
  s.volume->SetProperty(s.property);
  s.volume->VisibilityOff();
  s.renderer->AddVolume(s.volume);
  s.apply_preset();

  // Tool, contacts, proxies, springs, arrow.
  s.tool_actor = make_actor(tool_geometry("finger:37"), false);
  s.tool_actor->GetProperty()->SetColor(0.93, 0.78, 0.66);
  s.tool_actor->GetProperty()->SetSpecular(0.3);
  s.tool_actor->VisibilityOff();
  s.renderer->AddActor(s.tool_actor);
  s.contact_actor = make_actor(s.contact_poly, true);
  s.contact_actor->GetProperty()->SetPointSize(7.0);
  s.contact_actor->GetProperty()->SetRenderPointsAsSpheres(true);
  s.proxy_actor = make_actor(s.proxy_poly, true);
  s.proxy_actor->GetProperty()->SetPointSize(6.0);
  s.proxy_actor->GetProperty()->SetRenderPointsAsSpheres(true);
  s.spring_actor = make_actor(s.spring_poly, false);
  s.spring_actor->GetProperty()->SetColor(1.0, 0.55, 0.1);
  s.spring_actor->GetProperty()->SetLineWidth(2.0);
  s.spring_actor->GetProperty()->LightingOff();
  for (auto* actor : {s.contact_actor.Get(), s.proxy_actor.Get(), s.spring_actor.Get()}) {
    actor->VisibilityOff();
    s.renderer->AddActor(actor);
  }
  s.arrow_source->SetTipResolution(16);
  s.arrow_source->SetShaftResolution(16);
  vtkNew<vtkPolyData> arrow_poly;
  s.arrow_source->Update();
  arrow_poly->DeepCopy(s.arrow_source->GetOutput());
  s.arrow_actor = make_actor(arrow_poly, false);
  s.arrow_actor->GetProperty()->SetColor(0.95, 0.2, 0.2);
  s.arrow_actor->VisibilityOff();
  s.renderer->AddActor(s.arrow_actor);
  s.shadow_source->SetInnerRadius(0.72);
  s.shadow_source->SetOuterRadius(1.0);
  s.shadow_source->SetCircumferentialResolution(48);
  s.shadow_source->Update();

  // HUD text and banner.
  s.hud->GetTextProperty()->SetFontFamilyToCourier();
  s.hud->GetTextProperty()->SetFontSize(15);
  s.hud->GetTextProperty()->SetColor(0.9, 0.95, 0.9);
  s.hud->GetTextProperty()->SetVerticalJustificationToTop();
  s.hud->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
  s.hud->GetPositionCoordinate()->SetValue(0.01, 0.985);
  s.renderer->AddActor2D(s.hud);
  s.banner->GetTextProperty()->SetFontSize(24);
  s.banner->GetTextProperty()->SetBold(true);
  s.banner->GetTextProperty()->SetColor(1.0, 1.0, 1.0);
  s.banner->GetTextProperty()->SetBackgroundColor(0.75, 0.05, 0.05);
  s.banner->GetTextProperty()->SetBackgroundOpacity(0.85);
  s.banner->GetTextProperty()->SetJustificationToCentered();
  s.banner->GetTextProperty()->SetVerticalJustificationToTop();
  s.banner->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
  s.banner->GetPositionCoordinate()->SetValue(0.5, 0.97);
  s.renderer->AddActor2D(s.banner);
  s.force_label->GetTextProperty()->SetFontSize(14);
  s.force_label->GetTextProperty()->SetColor(1.0, 0.85, 0.6);
  s.force_label->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
  s.force_label->GetPositionCoordinate()->SetValue(0.62, 0.31);
  s.renderer->AddActor2D(s.force_label);

  // Force chart: |f| and its components over the last chart_seconds.
  for (const char* name : {"t", "|f|", "fx", "fy", "fz"}) {
    vtkNew<vtkFloatArray> column;
    column->SetName(name);
    s.chart_table->AddColumn(column);
  }
  s.chart_table->SetNumberOfRows(2);
  for (vtkIdType r = 0; r < 2; ++r)
    for (vtkIdType c = 0; c < 5; ++c) s.chart_table->SetValue(r, c, vtkVariant(0.0f));
  const double line_colours[4][3] = {
      {255, 255, 255}, {255, 90, 90}, {90, 220, 90}, {110, 150, 255}};
  for (int c = 1; c <= 4; ++c) {
    vtkPlot* line = s.chart->AddPlot(vtkChart::LINE);
    line->SetInputData(s.chart_table, 0, c);
    line->SetColor(line_colours[c - 1][0] / 255, line_colours[c - 1][1] / 255,
                   line_colours[c - 1][2] / 255);
    line->SetWidth(c == 1 ? 2.0f : 1.0f);
  }
  s.chart->GetAxis(vtkAxis::BOTTOM)->SetTitle("t (s)");
  s.chart->GetAxis(vtkAxis::LEFT)->SetTitle("N");
  s.chart->SetShowLegend(true);
  s.chart->GetBackgroundBrush()->SetColorF(0.1, 0.1, 0.12, 0.75);
  s.chart_scene->AddItem(s.chart);
  s.chart_actor->SetScene(s.chart_scene);
  s.chart_renderer->AddActor(s.chart_actor);
  s.chart_scene->SetRenderer(s.chart_renderer);
  s.apply_visibility();
}

RenderScene::~RenderScene() {
  if (impl_ && impl_->window) {
    impl_->window->RemoveRenderer(impl_->renderer);
    impl_->window->RemoveRenderer(impl_->chart_renderer);
  }
}

void RenderScene::Impl::build_volume(const RenderVolume& source) {
  const std::int64_t n = source.dims[0] * source.dims[1] * source.dims[2];
  if (n <= 0 || static_cast<std::int64_t>(source.d_surf.size()) != n) return;
  render_scalars = compose_render_scalar(source.d_surf, source.d_bone);
  image->SetDimensions(static_cast<int>(source.dims[0]), static_cast<int>(source.dims[1]),
                       static_cast<int>(source.dims[2]));
  image->SetSpacing(source.spacing[0], source.spacing[1], source.spacing[2]);
  image->SetOrigin(0, 0, 0);
  scalar_array->SetName("render_scalar");
  scalar_array->SetNumberOfComponents(1);
  // No copy: the array reads render_scalars, which the deformer writes in place.
  scalar_array->SetArray(render_scalars.data(), n, 1);
  image->GetPointData()->SetScalars(scalar_array);
  scalar_array->Modified();
  image->Modified();
  mapper->SetInputData(image);
  mapper->SetSampleDistance(0.5 *
                            std::min({source.spacing[0], source.spacing[1], source.spacing[2]}));
  volume->VisibilityOn();
  deformer = settings.deformation
                 ? std::make_unique<SkinDeformer>(source.dims, source.spacing, render_scalars,
                                                  settings.deformer)
                 : nullptr;
  if (!camera_placed) {
    place_camera();
    camera_placed = true;
  }
}

void RenderScene::Impl::apply_preset() {
  colour->RemoveAllPoints();
  opacity->RemoveAllPoints();
  for (const ControlPoint& point : preset.points) {
    const double v = point_value(point, window_level);
    colour->AddRGBPoint(v, point.rgb[0], point.rgb[1], point.rgb[2]);
    opacity->AddPoint(v, point.opacity);
  }
  property->SetShade(preset.shade ? 1 : 0);
}

void RenderScene::Impl::place_camera() {
  double bounds[6] = {0, 1, 0, 1, 0, 1};
  if (volume_source) {
    for (int a = 0; a < 3; ++a) {
      bounds[2 * a] = 0;
      bounds[2 * a + 1] =
          static_cast<double>(volume_source->dims[a] - 1) * volume_source->spacing[a];
    }
  }
  const Vec3d centre{0.5 * (bounds[0] + bounds[1]), 0.5 * (bounds[2] + bounds[3]),
                     0.5 * (bounds[4] + bounds[5])};
  const double radius =
      0.5 * std::sqrt(std::pow(bounds[1] - bounds[0], 2) + std::pow(bounds[3] - bounds[2], 2) +
                      std::pow(bounds[5] - bounds[4], 2));
  vtkCamera* camera = renderer->GetActiveCamera();
  camera->SetViewAngle(30.0);
  const double distance = settings.camera_distance_mm > 0
                              ? settings.camera_distance_mm
                              : std::max(radius, 1.0) / std::sin(std::numbers::pi / 12.0);
  // Anterior view: from -y looking +y, head (+z) up; then azimuth and elevation.
  camera->SetFocalPoint(centre.x, centre.y, centre.z);
  camera->SetPosition(centre.x, centre.y - distance, centre.z);
  camera->SetViewUp(0, 0, 1);
  camera->Azimuth(settings.camera_azimuth_deg);
  camera->Elevation(settings.camera_elevation_deg);
  camera->OrthogonalizeViewUp();
  renderer->ResetCameraClippingRange(bounds);
}

void RenderScene::Impl::update_tool(const LatestState& state) {
  if (state.scene != scene) {
    scene = state.scene;
    const std::string name = scene ? scene->tool : std::string("finger:37");
    if (name != tool_name) {
      tool_name = name;
      vtkPolyDataMapper::SafeDownCast(tool_actor->GetMapper())->SetInputData(tool_geometry(name));
    }
  }
  const FrameState& frame = state.frame;
  const bool show = frame.valid && tool_glyphs;
  tool_actor->SetVisibility(show);
  contact_actor->SetVisibility(show);
  proxy_actor->SetVisibility(show);
  spring_actor->SetVisibility(show);
  if (!frame.valid) {
    arrow_actor->VisibilityOff();
    return;
  }
  tool_actor->SetUserMatrix(pose_matrix(frame.pose));

  std::vector<Vec3d> contact_points, proxies;
  std::vector<std::array<unsigned char, 3>> contact_colours, proxy_colours;
  std::vector<std::pair<Vec3d, Vec3d>> springs;
  if (!frame.contacts.empty()) {
    for (const ContactState& c : frame.contacts) {
      contact_points.push_back(c.x);
      contact_colours.push_back(c.in_contact ? std::array<unsigned char, 3>{40, 220, 80}
                                             : std::array<unsigned char, 3>{150, 150, 160});
      if (c.in_contact) {
        proxies.push_back(c.p);
        proxy_colours.push_back({255, 220, 40});
        springs.emplace_back(c.x, c.p);
      }
    }
  } else if (scene) {  // no per-contact data: the tool's points at the pose, uncoloured
    for (const Vec3d& p : scene->tool_points) {
      contact_points.push_back(frame.pose.position + rotate(normalized(frame.pose.orientation), p));
      contact_colours.push_back({150, 150, 160});
    }
  }
  set_points(contact_poly, contact_points, contact_colours);
  set_points(proxy_poly, proxies, proxy_colours);
  set_lines(spring_poly, springs);
  contact_poly->Modified();
  proxy_poly->Modified();
  spring_poly->Modified();

  const double f = norm(frame.force);
  if (show && f > 1e-3) {
    const double length = std::max(f * settings.arrow_mm_per_newton, 2.0);
    arrow_actor->SetUserMatrix(
        frame_matrix(frame.pose.position, frame.force, 0, {length, 30.0, 30.0}));
    arrow_actor->VisibilityOn();
  } else {
    arrow_actor->VisibilityOff();
  }
}

// The fingertip's spherical shadow: along the tool's -z from each pad centre, the first point
// inside the skin (D_surf > 0) of the undeformed map; a dark ring on the skin there, normal to
// it, whose radius grows and darkness fades with the pad's height above the skin.
void RenderScene::Impl::update_shadow(const LatestState& state) {
  const std::vector<Vec3d> pads = pad_centres(tool_name);
  while (shadow_actors.size() < pads.size()) {
    vtkNew<vtkPolyData> disk;
    disk->DeepCopy(shadow_source->GetOutput());
    auto actor = make_actor(disk, false);
    actor->GetProperty()->LightingOff();
    renderer->AddActor(actor);
    shadow_actors.push_back(actor);
  }
  for (auto& actor : shadow_actors) actor->VisibilityOff();
  if (!state.frame.valid || !volume_source || !tool_glyphs) return;
  const RenderVolume& vol = *volume_source;
  const Quat q = normalized(state.frame.pose.orientation);
  if (!std::isfinite(q.w)) return;
  const Vec3d down = rotate(q, {0, 0, -1});
  const double step = 0.5 * std::min({vol.spacing[0], vol.spacing[1], vol.spacing[2]});
  const double radius = pad_radius(tool_name);
  for (std::size_t n = 0; n < pads.size(); ++n) {
    const Vec3d start = state.frame.pose.position + rotate(q, pads[n]);
    double previous = sample(vol, vol.d_surf, start, -1e9);
    if (previous > 0) continue;  // already inside: the contacts tell the story
    for (double h = step; h <= 250.0; h += step) {
      const Vec3d p = start + down * h;
      const double d = sample(vol, vol.d_surf, p, -1e9);
      if (d > 0 && previous > -1e8) {
        const double height = h - step * d / (d - previous);  // linear zero crossing
        const Vec3d skin = start + down * height;
        const double e = step;
        const Vec3d gradient{sample(vol, vol.d_surf, skin + Vec3d{e, 0, 0}, 0) -
                                 sample(vol, vol.d_surf, skin - Vec3d{e, 0, 0}, 0),
                             sample(vol, vol.d_surf, skin + Vec3d{0, e, 0}, 0) -
                                 sample(vol, vol.d_surf, skin - Vec3d{0, e, 0}, 0),
                             sample(vol, vol.d_surf, skin + Vec3d{0, 0, e}, 0) -
                                 sample(vol, vol.d_surf, skin - Vec3d{0, 0, e}, 0)};
        const Vec3d outward = norm(gradient) > 0 ? -gradient : -down;
        const double r = radius + 0.2 * height;
        const Vec3d unit_out = outward * (1.0 / norm(outward));
        auto& actor = shadow_actors[n];
        actor->SetUserMatrix(frame_matrix(skin + unit_out * 1.0, outward, 2, {r, r, 1.0}));
        const double darkness = std::clamp(std::exp(-height / 60.0), 0.15, 1.0);
        const double grey = 0.55 * (1.0 - darkness);
        actor->GetProperty()->SetColor(grey, grey, grey + 0.05);
        actor->VisibilityOn();
        break;
      }
      if (d > -1e8) previous = d;
    }
  }
}

void RenderScene::Impl::update_chart(const LatestState& state) {
  const auto& history = state.force_history;
  std::size_t first = 0;
  const double t_end = history.empty() ? 0.0 : history.back().t_s;
  while (first < history.size() && history[first].t_s < t_end - settings.chart_seconds) ++first;
  const std::size_t rows = history.size() - first;
  if (rows < 2) {
    chart_table->SetNumberOfRows(2);
    for (vtkIdType r = 0; r < 2; ++r) {
      chart_table->SetValue(r, 0, vtkVariant(static_cast<float>(r - 1)));
      for (vtkIdType c = 1; c < 5; ++c) chart_table->SetValue(r, c, vtkVariant(0.0f));
    }
  } else {
    chart_table->SetNumberOfRows(static_cast<vtkIdType>(rows));
    auto* t = vtkFloatArray::SafeDownCast(chart_table->GetColumn(0));
    auto* fm = vtkFloatArray::SafeDownCast(chart_table->GetColumn(1));
    auto* fx = vtkFloatArray::SafeDownCast(chart_table->GetColumn(2));
    auto* fy = vtkFloatArray::SafeDownCast(chart_table->GetColumn(3));
    auto* fz = vtkFloatArray::SafeDownCast(chart_table->GetColumn(4));
    for (std::size_t r = 0; r < rows; ++r) {
      const ForceSample& s = history[first + r];
      const auto row = static_cast<vtkIdType>(r);
      t->SetValue(row, static_cast<float>(s.t_s - t_end));
      fm->SetValue(row, static_cast<float>(norm(s.force)));
      fx->SetValue(row, static_cast<float>(s.force.x));
      fy->SetValue(row, static_cast<float>(s.force.y));
      fz->SetValue(row, static_cast<float>(s.force.z));
    }
  }
  chart_table->Modified();
  chart->RecalculateBounds();
  chart->GetAxis(vtkAxis::BOTTOM)->SetRange(-settings.chart_seconds, 0.0);
  chart->GetAxis(vtkAxis::BOTTOM)->SetBehavior(vtkAxis::FIXED);
}

void RenderScene::Impl::apply_visibility() {
  hud->SetVisibility(overlays);
  banner->SetVisibility(overlays && !banner_string.empty());
  force_label->SetVisibility(overlays);
  chart_actor->SetVisibility(overlays);
  chart_renderer->SetDraw(overlays);
}

void RenderScene::update_state(const LatestState& state, const HudInputs& inputs) {
  Impl& s = *impl_;
  if (state.volume && (state.volume != s.volume_source || state.connection != s.connection)) {
    s.volume_source = state.volume;
    s.connection = state.connection;
    s.build_volume(*state.volume);
  }
  s.update_tool(state);
  s.update_shadow(state);

  // Contacts for the deformation step.
  s.deform_contacts.clear();
  if (state.frame.valid)
    for (const ContactState& c : state.frame.contacts)
      if (c.in_contact) s.deform_contacts.push_back({c.x, c.p});

  if (s.overlays) {
    HudInputs shown = inputs;
    shown.preset = s.preset.id;
    shown.window = s.window_level;
    shown.deformation = s.settings.deformation;
    s.hud_string = hud_text(state, shown);
    s.banner_string = banner_text(state);
    s.hud->SetInput(s.hud_string.c_str());
    s.banner->SetInput(s.banner_string.empty() ? " " : s.banner_string.c_str());
    s.force_label->SetInput(force_text(state).c_str());
    s.update_chart(state);
  }
  s.apply_visibility();
}

DeformResult RenderScene::update_deformation() {
  Impl& s = *impl_;
  if (!s.deformer || s.render_scalars.empty()) return {};
  const DeformResult result = s.deformer->update(s.deform_contacts, s.render_scalars);
  // Anything written (a new ROI, or the last one restored): the texture must be re-uploaded.
  if (result.active || s.deform_was_active) {
    s.scalar_array->Modified();
    s.image->Modified();
  }
  s.deform_was_active = result.active;
  return result;
}

void RenderScene::render() {
  impl_->window->Render();
}

bool RenderScene::has_volume() const {
  return impl_->volume_source != nullptr;
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
  impl_->preset = make_preset(id);
  impl_->window_level = impl_->preset.window;
  impl_->apply_preset();
}

PresetId RenderScene::preset() const {
  return impl_->preset.id;
}

void RenderScene::adjust_window(double dlevel, double width_factor) {
  impl_->window_level = palp::view::adjust_window(impl_->window_level, dlevel, width_factor);
  impl_->apply_preset();
}

Window RenderScene::window() const {
  return impl_->window_level;
}

void RenderScene::set_tool_glyphs_visible(bool visible) {
  impl_->tool_glyphs = visible;
  if (!visible) {
    for (auto* actor :
         {impl_->tool_actor.Get(), impl_->contact_actor.Get(), impl_->proxy_actor.Get(),
          impl_->spring_actor.Get(), impl_->arrow_actor.Get()})
      actor->VisibilityOff();
    for (auto& actor : impl_->shadow_actors) actor->VisibilityOff();
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
  return impl_->hud_string;
}
const std::string& RenderScene::last_banner_text() const {
  return impl_->banner_string;
}
const std::vector<float>& RenderScene::render_scalars() const {
  return impl_->render_scalars;
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
