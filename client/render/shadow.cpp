// The fingertip's shadow on the skin (see shadow.hpp).
#include "render/shadow.hpp"

#include <vtkPolyData.h>
#include <vtkProperty.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "base/errors.hpp"
#include "model/tool.hpp"
#include "render/glyph_geometry.hpp"

namespace palp::view {

namespace {

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
  const double g[3] = {(p.x - volume.origin[0]) / volume.spacing[0],
                       (p.y - volume.origin[1]) / volume.spacing[1],
                       (p.z - volume.origin[2]) / volume.spacing[2]};
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

}  // namespace

FingertipShadow::FingertipShadow(vtkRenderer* renderer) : renderer_(renderer) {
  source_->SetInnerRadius(0.72);
  source_->SetOuterRadius(1.0);
  source_->SetCircumferentialResolution(48);
  source_->Update();
}

// The fingertip's spherical shadow: along the tool's -z from each pad centre, the first point
// inside the skin (D_surf > 0) of the undeformed map; a dark ring on the skin there, normal to
// it, whose radius grows and darkness fades with the pad's height above the skin.
void FingertipShadow::update(const FrameState& frame, const std::string& tool_name,
                             const RenderVolume* volume, bool glyphs) {
  const std::vector<Vec3d> pads = pad_centres(tool_name);
  while (actors_.size() < pads.size()) {
    vtkNew<vtkPolyData> disk;
    disk->DeepCopy(source_->GetOutput());
    auto actor = make_actor(disk, false);
    actor->GetProperty()->LightingOff();
    renderer_->AddActor(actor);
    actors_.push_back(actor);
  }
  for (auto& actor : actors_) actor->VisibilityOff();
  if (!frame.valid || !volume || !glyphs) return;
  const RenderVolume& vol = *volume;
  const Quat q = normalized(frame.pose.orientation);
  if (!std::isfinite(q.w)) return;
  const Vec3d down = rotate(q, {0, 0, -1});
  const double step = 0.5 * std::min({vol.spacing[0], vol.spacing[1], vol.spacing[2]});
  const double radius = pad_radius(tool_name);
  for (std::size_t n = 0; n < pads.size(); ++n) {
    const Vec3d start = frame.pose.position + rotate(q, pads[n]);
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
        auto& actor = actors_[n];
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

void FingertipShadow::hide() {
  for (auto& actor : actors_) actor->VisibilityOff();
}

}  // namespace palp::view
