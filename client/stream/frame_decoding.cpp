// palp.v1 -> plain structs: see frame_decoding.hpp.
#include "stream/frame_decoding.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include "base/volume.hpp"
#include "stream/protocol_checks.hpp"
#include "wire/messages.hpp"

namespace palp::view::net {

namespace {

// SceneInfo.structures: at most kMaxStructures, labels 1..kMaxStructures increasing, names and
// kinds within the name limit.
void decode_structures(const v1::SceneInfo& s, SceneDescription& scene) {
  if (static_cast<std::size_t>(s.structures_size()) > palp::wire::kMaxStructures)
    throw ProtocolViolation("SceneInfo: " + std::to_string(s.structures_size()) +
                            " structures, at most " +
                            std::to_string(palp::wire::kMaxStructures));
  std::uint32_t last = 0;
  for (const v1::Structure& st : s.structures()) {
    if (st.label() <= last || st.label() > palp::wire::kMaxStructures)
      throw ProtocolViolation("SceneInfo: structure label " + std::to_string(st.label()) +
                              " not increasing within 1.." +
                              std::to_string(palp::wire::kMaxStructures));
    if (st.name().size() > palp::wire::kMaxNameBytes ||
        st.kind().size() > palp::wire::kMaxNameBytes)
      throw ProtocolViolation("SceneInfo: a structure's name or kind is too long");
    last = st.label();
    scene.structures.push_back({static_cast<std::uint8_t>(st.label()), st.name(), st.kind()});
  }
}

}  // namespace

std::shared_ptr<SceneDescription> decode_scene(const v1::SceneInfo& s) {
  const v1::Grid& g = s.grid();
  if (g.dims_size() != 3 || g.spacing_size() != 3)
    throw ProtocolViolation("SceneInfo: the grid needs 3 dims and 3 spacings");
  // palpd serves what prep accepts: [kMinSpacingMm, kMaxSpacingMm] per axis (base/volume.hpp).
  // Beyond it (1e300, 1e-300) a render frame never returned once frames arrived (issue 37).
  for (int a = 0; a < 3; ++a)
    if (!(g.spacing(a) >= kMinSpacingMm && g.spacing(a) <= kMaxSpacingMm)) {
      char text[160];
      std::snprintf(text, sizeof text,
                    "SceneInfo: grid spacing (%g, %g, %g) mm is outside [%g, %g] mm per axis",
                    g.spacing(0), g.spacing(1), g.spacing(2), kMinSpacingMm, kMaxSpacingMm);
      throw ProtocolViolation(text);
    }
  auto scene = std::make_shared<SceneDescription>();
  for (int a = 0; a < 3; ++a) {
    if (g.dims(a) < 1 || g.dims(a) > (std::int64_t{1} << 31))
      throw ProtocolViolation("SceneInfo: grid dimension " + std::to_string(g.dims(a)));
    scene->dims[a] = g.dims(a);
    scene->spacing[a] = g.spacing(a);
    if (g.origin_size() == 3) scene->origin[a] = g.origin(a);
  }
  if (g.direction_size() == 9)
    for (int i = 0; i < 9; ++i) scene->direction[i] = g.direction(i);
  scene->source = s.source();
  for (const auto& [key, value] : s.metadata()) scene->metadata[key] = value;
  scene->tool = s.tool().name();
  scene->tool_points.reserve(static_cast<std::size_t>(s.tool().points_size()));
  for (const v1::Vec3& p : s.tool().points())
    scene->tool_points.push_back(palp::wire::from_proto(p));
  scene->c = s.parameters().c();
  scene->k = s.parameters().k();
  scene->bone_fmax = s.parameters().bone_fmax();
  scene->bone_enabled = s.parameters().bone_enabled();
  const double bpm = s.parameters().pulse_bpm();
  scene->pulse_bpm = std::isfinite(bpm) ? std::clamp(bpm, 0.0, 1e3) : 0.0;
  decode_structures(s, *scene);
  scene->device = s.device();
  scene->device_profile = s.device_profile();
  scene->tick_rate_hz = s.tick_rate_hz();
  scene->device_renders_force = s.device_renders_force();
  if (s.has_registration()) {
    const v1::Registration& r = s.registration();
    SceneDescription::Placement p;
    if (r.rotation_size() != 9 || r.workspace_half_mm_size() != 3)
      throw ProtocolViolation("SceneInfo: the registration needs 9 rotation values, 3 extents");
    for (int i = 0; i < 9; ++i) {
      if (!std::isfinite(r.rotation(i)) || std::fabs(r.rotation(i)) > 1.0 + 1e-6)
        throw ProtocolViolation("SceneInfo: registration rotation out of range");
      p.rotation[static_cast<std::size_t>(i)] = r.rotation(i);
    }
    if (!positive_finite(r.scale()) || r.scale() > 100.0)
      throw ProtocolViolation("SceneInfo: registration scale must be in (0, 100]");
    p.scale = r.scale();
    p.workspace_half_mm = {r.workspace_half_mm(0), r.workspace_half_mm(1), r.workspace_half_mm(2)};
    if (!positive_finite(p.workspace_half_mm.x) || !positive_finite(p.workspace_half_mm.y) ||
        !positive_finite(p.workspace_half_mm.z) || p.workspace_half_mm.x > 1e4 ||
        p.workspace_half_mm.y > 1e4 || p.workspace_half_mm.z > 1e4)
      throw ProtocolViolation("SceneInfo: registration workspace must be in (0, 10000] mm");
    p.home = palp::wire::from_proto(r.home());
    p.home_skin = palp::wire::from_proto(r.home_skin());
    if (!is_finite(p.home) || !is_finite(p.home_skin))
      throw ProtocolViolation("SceneInfo: registration home not finite");
    if (r.home_site().size() > palp::wire::kMaxNameBytes || r.axes().size() > 8)
      throw ProtocolViolation("SceneInfo: registration names too long");
    p.home_site = r.home_site();
    p.axes = r.axes();
    scene->placement = p;
  }
  return scene;
}

FrameState decode_frame(const v1::HapticFrame& f) {
  FrameState frame;
  frame.valid = true;
  frame.seq = f.seq();
  frame.server_time_ns = f.server_time_ns();
  frame.pose = palp::wire::from_proto(f.device_pose());
  frame.force = palp::wire::from_proto(f.force());
  frame.torque = palp::wire::from_proto(f.torque());
  frame.u = palp::wire::from_proto(f.displacement());
  frame.n_contact = f.n_contact();
  frame.contact_points = f.contact_points();
  frame.contacts.reserve(static_cast<std::size_t>(f.contacts_size()));
  for (const v1::Contact& pc : f.contacts()) {
    ContactState cs;
    cs.x = palp::wire::from_proto(pc.position());
    cs.s = palp::wire::from_proto(pc.surface());
    cs.p = palp::wire::from_proto(pc.proxy());
    cs.f = palp::wire::from_proto(pc.force());
    cs.in_contact = pc.in_contact();
    frame.contacts.push_back(cs);
  }
  frame.tick_status = f.tick_status();
  frame.safety_status = f.safety_status();
  frame.fault = f.fault();
  frame.device_state = palp::wire::from_proto(f.device_state());
  // The pulse, kept to its ranges whatever came (it only colours the artery and fills the HUD).
  const auto within = [](double v, double hi) { return std::isfinite(v) ? std::clamp(v, 0.0, hi) : 0.0; };
  frame.pulse_wave = within(f.pulse_wave(), 1.0);
  frame.pulse_force = within(f.pulse_force(), 1e4);
  frame.organ_force = within(f.organ_force(), 1e4);
  if (f.has_pulse_bpm()) frame.pulse_bpm = within(f.pulse_bpm(), 1e3);
  return frame;
}

}  // namespace palp::view::net
