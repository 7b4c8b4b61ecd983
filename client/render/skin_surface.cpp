// The skin preset on the sub-voxel skin (see skin_surface.hpp for the composition and its width).
#include "render/skin_surface.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "base/errors.hpp"

namespace palp::view {

double skin_ramp_half_width_mm(const std::array<double, 3>& spacing) {
  const double diagonal =
      std::sqrt(spacing[0] * spacing[0] + spacing[1] * spacing[1] + spacing[2] * spacing[2]);
  return std::max<double>(kRampHalfWidthMm, 2.0 * diagonal);
}

namespace {

// One pass along the axis whose lines are `n` long with `inner` values between neighbours: `d`
// as [outer][n][inner], each block of `inner` values smoothed with its two neighbours at once
// (contiguous, whatever the axis). `before` keeps the previous block as it was before its own
// smoothing; past the ends the line is extrapolated linearly.
void smooth_axis(std::span<float> d, std::int64_t n, std::int64_t inner,
                 std::vector<float>& before) {
  const auto block = static_cast<std::size_t>(inner);
  const std::size_t line = block * static_cast<std::size_t>(n);
  before.resize(block);
  for (std::size_t start = 0; start + line <= d.size(); start += line) {
    float* first = d.data() + start;
    for (std::size_t x = 0; x < block; ++x) before[x] = 2.0f * first[x] - first[block + x];
    for (std::int64_t t = 0; t < n; ++t) {
      float* here = first + static_cast<std::size_t>(t) * block;
      const bool last = t + 1 == n;
      for (std::size_t x = 0; x < block; ++x) {
        const float value = here[x];
        const float after = last ? 2.0f * value - before[x] : here[block + x];
        here[x] = 0.25f * before[x] + 0.5f * value + 0.25f * after;
        before[x] = value;
      }
    }
  }
}

}  // namespace

void smooth_distance(std::span<float> d, const std::array<std::int64_t, 3>& dims) {
  std::vector<float> before;
  std::int64_t inner = 1;
  for (int a = 0; a < 3; ++a) {
    if (dims[a] >= 2) smooth_axis(d, dims[a], inner, before);
    inner *= dims[a];
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
