// The skin preset on the sub-voxel skin (see skin_surface.hpp for the composition and its width).
#include "render/skin_surface.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "base/errors.hpp"

namespace palp::view {

double skin_ramp_half_width_mm(const std::array<double, 3>& spacing) {
  const double diagonal =
      std::sqrt(spacing[0] * spacing[0] + spacing[1] * spacing[1] + spacing[2] * spacing[2]);
  return std::max<double>(kRampHalfWidthMm, 2.0 * diagonal);
}

void smooth_distance(std::span<float> d, const std::array<std::int64_t, 3>& dims) {
  const std::array<std::int64_t, 3> stride{1, dims[0], dims[0] * dims[1]};
  for (int a = 0; a < 3; ++a) {
    const std::int64_t n = dims[a];
    if (n < 2) continue;
    const int b = a == 0 ? 1 : 0, c = a == 2 ? 1 : 2;  // the other two axes
    for (std::int64_t v = 0; v < dims[c]; ++v)
      for (std::int64_t u = 0; u < dims[b]; ++u) {
        float* line = d.data() + u * stride[b] + v * stride[c];
        const std::int64_t s = stride[a];
        // In place: `before` keeps the previous node's value from before its own smoothing.
        float before = 2.0f * line[0] - line[s];  // linear extrapolation past the end
        for (std::int64_t i = 0; i < n; ++i) {
          const float here = line[i * s];
          const float after = i + 1 < n ? line[(i + 1) * s] : 2.0f * here - before;
          line[i * s] = 0.25f * before + 0.5f * here + 0.25f * after;
          before = here;
        }
      }
  }
}

std::vector<float> compose_skin_scalar(std::span<const float> d_surf,
                                       const std::array<std::int64_t, 3>& dims,
                                       const std::array<double, 3>& spacing) {
  if (static_cast<std::int64_t>(d_surf.size()) != dims[0] * dims[1] * dims[2])
    throw UsageError("render volume: d_surf has " + std::to_string(d_surf.size()) + " values for " +
                     std::to_string(dims[0]) + " x " + std::to_string(dims[1]) + " x " +
                     std::to_string(dims[2]) + " voxels");
  std::vector<float> out(d_surf.begin(), d_surf.end());
  smooth_distance(out, dims);
  const auto w = static_cast<float>(skin_ramp_half_width_mm(spacing));
  for (float& v : out) v = kAirValue + kSkinStep * std::clamp((v + w) / (2.0f * w), 0.0f, 1.0f);
  for (std::int64_t k = 0; k < dims[2]; ++k)  // the field of view's cut closed
    for (std::int64_t j = 0; j < dims[1]; ++j) {
      const bool face = k == 0 || k + 1 == dims[2] || j == 0 || j + 1 == dims[1];
      float* row = out.data() + dims[0] * (j + dims[1] * k);
      if (face) {
        std::fill(row, row + dims[0], kAirValue);
      } else {
        row[0] = row[dims[0] - 1] = kAirValue;
      }
    }
  return out;
}

Preset make_skin_surface_preset() {
  Preset p;
  p.id = PresetId::Skin;
  p.name = to_string(PresetId::Skin);
  // t = 0 .. 1 is the step (-501 .. -499); the points beyond it span the whole of s.
  p.window = {kAirValue + 0.5 * kSkinStep, kSkinStepWidth};
  const std::array<double, 3> skin{0.93, 0.74, 0.64};
  p.points = {{-1000.0, skin, 0.0}, {0.0, skin, 0.0}, {1.0, skin, 0.95}, {1000.0, skin, 0.95}};
  p.shade = true;
  return p;
}

ScalarKind scalar_kind(PresetId preset, bool has_hu, bool skin_from_volume) {
  if (preset == PresetId::Skin && !skin_from_volume) return ScalarKind::Skin;
  return has_hu ? ScalarKind::Hu : ScalarKind::Maps;
}

Preset make_preset_on(ScalarKind kind, PresetId id) {
  if (kind == ScalarKind::Skin) return make_skin_surface_preset();
  return make_preset(id, kind == ScalarKind::Hu);
}

}  // namespace palp::view
