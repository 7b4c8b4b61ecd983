// The tool layer: tool, contacts, proxies, springs and force arrow (see tool_layer.hpp).
#include "render/tool_layer.hpp"

#include <vtkAppendPolyData.h>
#include <vtkCellArray.h>
#include <vtkCubeSource.h>
#include <vtkCylinderSource.h>
#include <vtkMatrix4x4.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkSphereSource.h>
#include <vtkTransform.h>
#include <vtkTransformPolyDataFilter.h>
#include <vtkUnsignedCharArray.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include "base/errors.hpp"
#include "model/tool.hpp"
#include "render/glyph_geometry.hpp"

namespace palp::view {

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

}  // namespace

ToolLayer::ToolLayer(vtkRenderer* renderer, double arrow_mm_per_newton)
    : arrow_mm_per_newton_(arrow_mm_per_newton) {
  tool_actor_ = make_actor(tool_geometry("finger:37"), false);
  tool_actor_->GetProperty()->SetColor(0.93, 0.78, 0.66);
  tool_actor_->GetProperty()->SetSpecular(0.3);
  tool_actor_->GetProperty()->SetOpacity(kToolOpacity);  // semi-transparent, as in the paper
  tool_actor_->VisibilityOff();
  renderer->AddActor(tool_actor_);
  contact_actor_ = make_actor(contact_poly_, true);
  contact_actor_->GetProperty()->SetPointSize(7.0);
  contact_actor_->GetProperty()->SetRenderPointsAsSpheres(true);
  proxy_actor_ = make_actor(proxy_poly_, true);
  proxy_actor_->GetProperty()->SetPointSize(6.0);
  proxy_actor_->GetProperty()->SetRenderPointsAsSpheres(true);
  spring_actor_ = make_actor(spring_poly_, false);
  spring_actor_->GetProperty()->SetColor(1.0, 0.55, 0.1);
  spring_actor_->GetProperty()->SetLineWidth(2.0);
  spring_actor_->GetProperty()->LightingOff();
  for (auto* actor : {contact_actor_.Get(), proxy_actor_.Get(), spring_actor_.Get()}) {
    actor->VisibilityOff();
    renderer->AddActor(actor);
  }
  arrow_source_->SetTipResolution(16);
  arrow_source_->SetShaftResolution(16);
  vtkNew<vtkPolyData> arrow_poly;
  arrow_source_->Update();
  arrow_poly->DeepCopy(arrow_source_->GetOutput());
  arrow_actor_ = make_actor(arrow_poly, false);
  arrow_actor_->GetProperty()->SetColor(0.95, 0.2, 0.2);
  arrow_actor_->VisibilityOff();
  renderer->AddActor(arrow_actor_);
}

void ToolLayer::update(const LatestState& state, bool glyphs) {
  if (state.scene != scene_) {
    scene_ = state.scene;
    const std::string name = scene_ ? scene_->tool : std::string("finger:37");
    if (name != tool_name_) {
      tool_name_ = name;
      vtkPolyDataMapper::SafeDownCast(tool_actor_->GetMapper())->SetInputData(tool_geometry(name));
    }
  }
  const FrameState& frame = state.frame;
  const bool show = frame.valid && glyphs;
  tool_actor_->SetVisibility(show);
  contact_actor_->SetVisibility(show);
  proxy_actor_->SetVisibility(show);
  spring_actor_->SetVisibility(show);
  if (!frame.valid) {
    arrow_actor_->VisibilityOff();
    return;
  }
  tool_actor_->SetUserMatrix(pose_matrix(frame.pose));

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
  } else if (scene_) {  // no per-contact data: the tool's points at the pose, uncoloured
    for (const Vec3d& p : scene_->tool_points) {
      contact_points.push_back(frame.pose.position + rotate(normalized(frame.pose.orientation), p));
      contact_colours.push_back({150, 150, 160});
    }
  }
  set_points(contact_poly_, contact_points, contact_colours);
  set_points(proxy_poly_, proxies, proxy_colours);
  set_lines(spring_poly_, springs);
  contact_poly_->Modified();
  proxy_poly_->Modified();
  spring_poly_->Modified();

  const double f = norm(frame.force);
  if (show && f > 1e-3) {
    const double length = std::max(f * arrow_mm_per_newton_, 2.0);
    arrow_actor_->SetUserMatrix(
        frame_matrix(frame.pose.position, frame.force, 0, {length, 30.0, 30.0}));
    arrow_actor_->VisibilityOn();
  } else {
    arrow_actor_->VisibilityOff();
  }
}

void ToolLayer::hide() {
  for (auto* actor : {tool_actor_.Get(), contact_actor_.Get(), proxy_actor_.Get(),
                      spring_actor_.Get(), arrow_actor_.Get()})
    actor->VisibilityOff();
}

}  // namespace palp::view
