// palpview's command line: the usage text, the options and their parsing (pure, testable
// without a display).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "render/patient_view.hpp"
#include "render/transfer_presets.hpp"

namespace palp::view {

// The --help text.
extern const char* const kUsage;

struct Options {
  std::string host;
  std::uint16_t port = 0;
  bool dds = false;  // --dds [DOMAIN] --rig NAME instead of --connect
  std::uint32_t dds_domain = 0;
  std::string dds_rig;
  bool controller = false;
  std::string token;
  std::string tls_ca, tls_pin, tls_cert, tls_key;
  std::string name = "palpview";
  double rate_hz = 120.0;
  std::uint32_t volume_max_dim = 256;
  PresetId preset = PresetId::Skin;
  bool deformation = true;
  bool show_outside = false, ct = true;
  bool skin_hu = false;  // --skin-hu: the skin preset on the CT's HU, not d_surf's zero level
  double chart_s = 30.0;
  double follow_mm = -1;  // -1: 150 unless --camera
  bool have_camera = false;
  int width = 1280, height = 800;
  double az = 0, el = 0, dist = 0;
  Anatomy view = Anatomy::Anterior;
  bool orientation_marker = true;
  bool overlays = true;
  bool tool_glyphs = true;
  bool show_landmarks = false;  // --show-landmarks: as if L were pressed at start
  std::string screenshot;
  int frames = 5;
  double timeout_s = 60.0;
  std::string script;
  std::string stats_json;
  double duration_s = 0;  // 0: until closed
};

// The options of argv; nullopt for -h/--help. UsageError for anything wrong or missing.
std::optional<Options> parse_options(int argc, char** argv);

}  // namespace palp::view
