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

std::vector<float> compose_ct_scalar(std::span<const std::int16_t> hu,
                                     std::span<const std::uint8_t> body, bool keep_outside) {
  if (body.size() != hu.size())
    throw UsageError("render volume: body has " + std::to_string(body.size()) + " values, hu " +
                     std::to_string(hu.size()));
  std::vector<float> out(hu.size());
  for (std::size_t n = 0; n < hu.size(); ++n)
    out[n] = (keep_outside || body[n]) ? static_cast<float>(hu[n]) : kOutsideValue;
  return out;
}

namespace {

// Presets on the CT's HU, in the spirit of 3D Slicer's CT presets. Opacity is per millimetre
// of ray (VTK's unit distance), so tissue that fills the body stays at a few per cent.
Preset make_ct_preset(PresetId id) {
  Preset p;
  p.id = id;
  p.name = to_string(id);
  const std::array<double, 3> skin{0.93, 0.74, 0.64}, bone{0.98, 0.95, 0.86};
  switch (id) {
    case PresetId::Skin:
      // Window -600 .. -100 HU: the air -> skin step (t = 0.5 at -350 HU) opaque and shaded.
      p.window = {-350.0, 500.0};
      p.points = {{-1.0, skin, 0.0},
                  {0.2, skin, 0.0},
                  {0.5, {0.90, 0.68, 0.58}, 0.7},
                  {1.0, skin, 0.95},
                  {4.0, skin, 0.95}};
      break;
    case PresetId::Bone:
      // Window 0 .. 600 HU: bone from 150 HU ivory and opaque by 600; the skin a translucent
      // veil (the -550 .. -300 HU of the air -> skin step only: fat and muscle stay clear).
      p.window = {300.0, 600.0};
      p.points = {{-1.083, skin, 0.0}, {-0.917, skin, 0.10}, {-0.5, skin, 0.10},
                  {-0.333, skin, 0.0}, {0.25, bone, 0.0},    {0.5, {0.9, 0.85, 0.75}, 0.6},
                  {1.0, bone, 0.95},   {4.0, bone, 1.0}};
      break;
    case PresetId::Soft:
      // Window -160 .. 240 HU (Slicer's soft tissue 40 / 400): fat clear, organs and muscle
      // faintly red, contrast (150 .. 300 HU) bright, bone white, the skin a faint veil.
      p.window = {40.0, 400.0};
      p.points = {{-0.975, skin, 0.0},
                  {-0.8, skin, 0.05},
                  {-0.35, skin, 0.0},
                  {0.4, {0.55, 0.25, 0.20}, 0.0},
                  {0.5, {0.75, 0.35, 0.30}, 0.012},
                  {0.7, {0.85, 0.45, 0.35}, 0.03},
                  {1.0, {1.0, 0.85, 0.7}, 0.3},
                  {2.15, {1.0, 1.0, 0.95}, 0.6}};
      break;
    case PresetId::Vessels:
      // Window -600 .. 600 HU: the air -> skin step (-700 .. -200 HU, most at -420) a faint
      // grey veil, bone (250 HU up) a fainter grey; fat, soft tissue, contrast and the lumens
      // clear, so the structures' own colours show through (structure_layer.hpp).
      p.window = {0.0, 1200.0};
      p.points = {{-0.083, {0.7, 0.7, 0.72}, 0.0}, {0.15, {0.7, 0.7, 0.72}, 0.08},
                  {0.333, {0.7, 0.7, 0.72}, 0.0},  {0.708, {0.8, 0.8, 0.8}, 0.0},
                  {0.875, {0.85, 0.85, 0.85}, 0.03}, {4.0, {0.9, 0.9, 0.9}, 0.03}};
      p.shade = false;
      break;
  }
  p.shade = true;
  return p;
}

}  // namespace

PresetId parse_preset(std::string_view name) {
  if (name == "skin") return PresetId::Skin;
  if (name == "bone") return PresetId::Bone;
  if (name == "soft") return PresetId::Soft;
  if (name == "vessels") return PresetId::Vessels;
  throw UsageError("unknown preset '" + std::string(name) + "' (skin, bone, soft or vessels)");
}

const char* to_string(PresetId id) {
  switch (id) {
    case PresetId::Skin:
      return "skin";
    case PresetId::Bone:
      return "bone";
    case PresetId::Soft:
      return "soft";
    case PresetId::Vessels:
      return "vessels";
  }
  return "?";
}

Preset make_preset(PresetId id, bool ct) {
  if (ct) return make_ct_preset(id);
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
    case PresetId::Vessels:
      // The skin step (-650 .. -350) a faint grey veil, the bone step (+550) a fainter one;
      // the tissue between clear. Window -1000 .. +1000.
      p.window = {0.0, 2000.0};
      p.points = {{0.15, {0.7, 0.7, 0.72}, 0.0},  {0.25, {0.7, 0.7, 0.72}, 0.08},
                  {0.35, {0.7, 0.7, 0.72}, 0.0},  {0.65, {0.8, 0.8, 0.8}, 0.0},
                  {0.8, {0.85, 0.85, 0.85}, 0.03}, {4.0, {0.9, 0.9, 0.9}, 0.03}};
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
