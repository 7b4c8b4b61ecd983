// How palpview draws the scene's structures (SceneDescription::structures, RenderVolume::labels):
// a colour and an opacity per structure, the artery's beating with the pulse, and the legend that
// names them. Pure: no VTK (structure_layer.hpp turns these into transfer functions and text).
//
//   artery  red, its colour and opacity rising from diastole (wave 0) to systole (wave 1)
//   vessel  blue (every lumen: veins and the arteries the artery does not cover)
//   organ   a colour of its own: liver, spleen, kidneys, ... from a table, any other a hue of the
//           golden-angle sequence (distinct, never red or blue); faint, so vessels show through
// Opacity is per millimetre of ray, as the volume presets' (transfer_presets.hpp).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "stream/stream_client.hpp"

namespace palp::view {

struct StructureStyle {
  std::uint8_t label = 0;
  std::string name, kind;
  std::array<double, 3> rgb{};
  double opacity = 0;  // per mm
};

// One style per structure, in the structures' order.
std::vector<StructureStyle> structure_styles(
    const std::vector<SceneDescription::Structure>& structures);

// The artery's style at `wave` (0 diastole .. 1 systole; clamped): from a dark red, opacity
// 0.25/mm, to a bright red, opacity 0.9/mm. Other kinds are returned as they are.
StructureStyle pulsed(const StructureStyle& style, double wave);

// The legend's lines, one per structure in label order: its name, and for the artery the beat
// ("artery  (pulse 72 bpm)", "artery  (no pulse)" at 0 bpm; the rate unknown: "artery").
std::vector<std::string> legend_lines(const std::vector<StructureStyle>& styles,
                                      const std::optional<double>& pulse_bpm);

}  // namespace palp::view
