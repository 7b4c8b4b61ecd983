// The structures' colours, the artery's beat and the legend: see structure_style.hpp.
#include "render/structure_style.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string_view>
#include <utility>

namespace palp::view {
namespace {

constexpr std::array<double, 3> kArteryDiastole{0.45, 0.03, 0.03}, kArterySystole{1.0, 0.12, 0.08};
constexpr double kArteryOpacityDiastole = 0.25, kArteryOpacitySystole = 0.9;
constexpr std::array<double, 3> kVessel{0.2, 0.4, 0.95};
constexpr double kVesselOpacity = 0.5, kOrganOpacity = 0.02;

// Organs a lab's label map commonly has, in the colours anatomy atlases give them.
constexpr std::pair<std::string_view, std::array<double, 3>> kOrganColours[] = {
    {"liver", {0.62, 0.32, 0.17}},       {"spleen", {0.55, 0.22, 0.45}},
    {"kidney", {0.85, 0.55, 0.25}},      {"stomach", {0.9, 0.75, 0.55}},
    {"pancreas", {0.95, 0.85, 0.35}},    {"gallbladder", {0.35, 0.6, 0.25}},
    {"heart", {0.75, 0.3, 0.35}},        {"lung", {0.85, 0.8, 0.85}},
    {"bladder", {0.9, 0.85, 0.45}},      {"intestine", {0.85, 0.65, 0.6}},
    {"colon", {0.8, 0.6, 0.5}},          {"adrenal", {0.9, 0.7, 0.2}},
};

// h in [0, 1): a colour of saturation 0.55, value 0.85.
std::array<double, 3> hue(double h) {
  const double s = 0.55, v = 0.85, x = 6.0 * h;
  const int sector = static_cast<int>(x) % 6;
  const double f = x - std::floor(x), p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  switch (sector) {
    case 0:
      return {v, t, p};
    case 1:
      return {q, v, p};
    case 2:
      return {p, v, t};
    case 3:
      return {p, q, v};
    case 4:
      return {t, p, v};
    default:
      return {v, p, q};
  }
}

// An organ's colour: the table's by name (kidney_left is a kidney), else the n-th hue of the
// golden-angle sequence, stepped past red (h near 0) and blue (h near 2/3).
std::array<double, 3> organ_colour(const std::string& name, int n) {
  for (const auto& [organ, rgb] : kOrganColours)
    if (name.rfind(organ, 0) == 0) return rgb;
  double h = std::fmod(0.12 + 0.618033988749895 * n, 1.0);
  if (h < 0.06 || h > 0.94) h = std::fmod(h + 0.12, 1.0);
  if (std::abs(h - 2.0 / 3.0) < 0.06) h += 0.12;
  return hue(std::fmod(h, 1.0));
}

}  // namespace

std::vector<StructureStyle> structure_styles(
    const std::vector<SceneDescription::Structure>& structures) {
  std::vector<StructureStyle> out;
  int organs = 0;
  for (const SceneDescription::Structure& s : structures) {
    StructureStyle style{s.label, s.name, s.kind, {}, kOrganOpacity};
    if (s.kind == "artery") {
      style = pulsed(style, 1.0);
    } else if (s.kind == "vessel") {
      style.rgb = kVessel;
      style.opacity = kVesselOpacity;
    } else {
      style.rgb = organ_colour(s.name, organs++);
    }
    out.push_back(std::move(style));
  }
  return out;
}

StructureStyle pulsed(const StructureStyle& style, double wave) {
  if (style.kind != "artery") return style;
  const double w = std::isfinite(wave) ? std::clamp(wave, 0.0, 1.0) : 0.0;
  StructureStyle out = style;
  for (std::size_t c = 0; c < 3; ++c)
    out.rgb[c] = kArteryDiastole[c] + w * (kArterySystole[c] - kArteryDiastole[c]);
  out.opacity = kArteryOpacityDiastole + w * (kArteryOpacitySystole - kArteryOpacityDiastole);
  return out;
}

std::vector<std::string> legend_lines(const std::vector<StructureStyle>& styles,
                                      const std::optional<double>& pulse_bpm) {
  std::vector<std::string> out;
  for (const StructureStyle& s : styles) {
    std::string line = s.name;
    if (s.kind == "artery" && pulse_bpm) {
      char text[48];
      std::snprintf(text, sizeof text, "  (pulse %.0f bpm)", *pulse_bpm);
      line += *pulse_bpm > 0 ? std::string(text) : std::string("  (no pulse)");
    }
    out.push_back(std::move(line));
  }
  return out;
}

}  // namespace palp::view
