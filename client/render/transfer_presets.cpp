// palpview's render scalar and transfer-function presets (see transfer_presets.hpp for the
// composition and the windowing rule). Pure arithmetic and tables.
#include "render/transfer_presets.hpp"

#include <algorithm>

#include "base/errors.hpp"

namespace palp::view {

namespace {

float ramp(float d) {
  return std::clamp((d + kRampHalfWidthMm) / (2.0f * kRampHalfWidthMm), 0.0f, 1.0f);
}

}  // namespace

float render_scalar(float d_surf, float d_bone, bool has_bone) {
  float v = kAirValue + kSkinStep * ramp(d_surf) +
            kSoftRise * std::clamp(d_surf / kSoftRiseDepthMm, 0.0f, 1.0f);
  if (has_bone) v += kBoneStep * ramp(d_bone);
  return v;
}

std::vector<float> compose_render_scalar(std::span<const float> d_surf,
                                         std::span<const float> d_bone) {
  const bool has_bone = !d_bone.empty();
  if (has_bone && d_bone.size() != d_surf.size())
    throw UsageError("render volume: d_bone has " + std::to_string(d_bone.size()) +
                     " values, d_surf " + std::to_string(d_surf.size()));
  std::vector<float> out(d_surf.size());
  for (std::size_t n = 0; n < d_surf.size(); ++n)
    out[n] = render_scalar(d_surf[n], has_bone ? d_bone[n] : 0.0f, has_bone);
  return out;
}

PresetId parse_preset(std::string_view name) {
  if (name == "skin") return PresetId::Skin;
  if (name == "bone") return PresetId::Bone;
  if (name == "soft") return PresetId::Soft;
  throw UsageError("unknown preset '" + std::string(name) + "' (skin, bone or soft)");
}

const char* to_string(PresetId id) {
  switch (id) {
    case PresetId::Skin:
      return "skin";
    case PresetId::Bone:
      return "bone";
    case PresetId::Soft:
      return "soft";
  }
  return "?";
}

Preset make_preset(PresetId id) {
  Preset p;
  p.id = id;
  p.name = to_string(id);
  switch (id) {
    case PresetId::Skin:
      // An opaque skin surface at the air -> skin step (value ~ -500), bone hidden behind it.
      // Window -700 .. -300: t = 0.5 is the skin iso-value.
      p.window = {-500.0, 400.0};
      p.points = {{0.0, {0.55, 0.35, 0.30}, 0.0},
                  {0.35, {0.80, 0.55, 0.45}, 0.0},
                  {0.65, {0.93, 0.72, 0.62}, 0.85},
                  {1.0, {0.96, 0.80, 0.70}, 0.95},
                  {4.0, {0.96, 0.80, 0.70}, 0.95}};
      p.shade = true;
      break;
    case PresetId::Bone:
      // Skin almost invisible, bone an opaque ivory surface at the bone step (~ +550).
      p.window = {550.0, 600.0};
      // t = -1.5 .. -1.25 is the skin step (-650 .. -500), 0.35 .. 0.55 the bone step.
      p.points = {{-1.5, {0.9, 0.7, 0.6}, 0.0},    {-1.25, {0.9, 0.7, 0.6}, 0.02},
                  {-0.3, {0.9, 0.6, 0.5}, 0.02},   {0.35, {0.85, 0.80, 0.70}, 0.0},
                  {0.55, {0.95, 0.92, 0.85}, 0.9}, {1.0, {1.0, 1.0, 0.95}, 1.0}};
      p.shade = true;
      break;
    case PresetId::Soft:
      // Translucent tissue whose colour and opacity rise with depth under the skin (0..60),
      // bone light and semi-opaque; the skin itself only a faint veil.
      p.window = {30.0, 60.0};
      p.points = {{-8.0, {0.6, 0.3, 0.3}, 0.0},  {-7.0, {0.8, 0.5, 0.4}, 0.01},
                  {0.0, {0.8, 0.4, 0.3}, 0.01},  {1.0, {0.7, 0.1, 0.1}, 0.03},
                  {9.0, {0.95, 0.9, 0.8}, 0.03}, {10.0, {1.0, 1.0, 0.95}, 0.5}};
      p.shade = false;
      break;
  }
  return p;
}

Window adjust_window(const Window& window, double dlevel, double width_factor) {
  Window w = window;
  w.level += dlevel;
  if (width_factor > 0) w.width *= width_factor;
  w.width = std::max(w.width, kMinWindowWidth);
  return w;
}

}  // namespace palp::view
