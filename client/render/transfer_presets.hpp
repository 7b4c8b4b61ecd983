// palpview's render scalar and its transfer-function presets. Pure: no VTK, no rendering; the
// scene (volume_layer.cpp) turns a Preset into VTK colour and opacity functions.
//
// Data flow: RenderVolume {d_surf, d_bone} (mm, positive inside) -> compose_render_scalar ->
// one pseudo-density per voxel (HU-like: air -1000, skin 0, soft tissue 0..+60 rising with depth
// under the skin, bone above +1000) -> the mapper samples it -> a Preset's control points,
// placed through the current window (level, width), give colour and opacity.
//
// Composition (docs/palpview.md): with ramp(d) = clamp((d + 2.5 mm) / 5 mm, 0, 1), linear over
// the five millimetres around each surface, so the shading gradient comes from the smooth part of
// the distance map rather than its voxel steps, and the deformation resample stays smooth:
//   v = -1000 + 1000 ramp(d_surf) + 60 clamp(d_surf / 30 mm, 0, 1) + 1000 ramp(d_bone)
// (the bone term is left out when the scene has no bone map).
//
// Windowing: a preset's control points sit at positions t (0..1 across the window); the value
// of a point is level + (t - 0.5) * width. Each preset has its own default window; shifting the
// level moves every point, scaling the width spreads or narrows them about the level.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace palp::view {

inline constexpr float kAirValue = -1000.0f;
inline constexpr float kSkinStep = 1000.0f;       // air -> skin
inline constexpr float kSoftRise = 60.0f;         // soft tissue gains this much ...
inline constexpr float kSoftRiseDepthMm = 30.0f;  // ... over this depth under the skin
inline constexpr float kBoneStep = 1000.0f;       // added inside bone
inline constexpr float kRampHalfWidthMm = 2.5f;   // each step is linear over +-2.5 mm

// The render scalar of one voxel (see the composition above).
float render_scalar(float d_surf, float d_bone, bool has_bone);

// The render scalars of a whole volume, i fastest. `d_bone` may be empty (no bone);
// otherwise it must have d_surf's size (UsageError).
std::vector<float> compose_render_scalar(std::span<const float> d_surf,
                                         std::span<const float> d_bone);

// The CT itself (RenderVolume::hu): its HU where the body mask is set, kOutsideValue outside
// (air: transparent in every preset) unless `keep_outside`. UsageError when the sizes differ.
inline constexpr float kOutsideValue = -1024.0f;
std::vector<float> compose_ct_scalar(std::span<const std::int16_t> hu,
                                     std::span<const std::uint8_t> body, bool keep_outside);

// Vessels: the body a faint veil, for the structures drawn over it (structure_layer.hpp).
enum class PresetId { Skin, Bone, Soft, Vessels };
inline constexpr int kPresetCount = 4;

// "skin" | "bone" | "soft" | "vessels"; UsageError otherwise.
PresetId parse_preset(std::string_view name);
const char* to_string(PresetId id);

struct ControlPoint {
  double t = 0;  // position across the window, 0..1 (may lie outside)
  std::array<double, 3> rgb{};
  double opacity = 0;
};

struct Window {
  double level = 0;  // render-scalar value at the window's centre
  double width = 1;  // render-scalar span of t = 0..1 (> 0)
};

struct Preset {
  PresetId id = PresetId::Skin;
  std::string name;
  Window window;                     // the default window
  std::vector<ControlPoint> points;  // increasing t
  bool shade = true;                 // lighting on (surfaces) or off (translucent)
};

// The preset's definition (default window included): on the CT's HU when `ct`, else on the
// pseudo-density composed from the distance maps.
Preset make_preset(PresetId id, bool ct = false);

// The render-scalar value of a control point under a window.
inline double point_value(const ControlPoint& point, const Window& window) {
  return window.level + (point.t - 0.5) * window.width;
}

// Windowing: the level shifted by `dlevel` and the width scaled by `width_factor` (> 0); the
// width never drops below kMinWindowWidth.
inline constexpr double kMinWindowWidth = 1.0;
Window adjust_window(const Window& window, double dlevel, double width_factor);

}  // namespace palp::view
