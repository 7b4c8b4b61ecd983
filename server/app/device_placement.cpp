// palpd's device placement: see device_placement.hpp.
#include "app/device_placement.hpp"

#include <cstdio>
#include <cstdlib>

#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "model/registration.hpp"
#include "scene/home_site.hpp"

namespace palp::app {

// The workspace half extents: "MM" or "X,Y,Z" (mm).
Vec3d workspace_half(const std::string& text) {
  double v[3];
  int n = 0;
  std::size_t start = 0;
  while (n < 3 && start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    const std::string part =
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    char* end = nullptr;
    v[n] = std::strtod(part.c_str(), &end);
    if (part.empty() || *end != '\0' || !(v[n] > 0.0 && v[n] <= 2000.0))
      throw UsageError("--workspace-mm needs MM or X,Y,Z, each in (0, 2000], got '" + text + "'");
    ++n;
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (n == 1) return {v[0], v[0], v[0]};
  if (n != 3) throw UsageError("--workspace-mm needs MM or X,Y,Z, got '" + text + "'");
  return {v[0], v[1], v[2]};
}

// Devices that drive a hand from a frame of their own (usb-haptic, falcon) are registered onto the
// patient; devices that move in the scene frame refuse registration options.
std::optional<net::SceneDescription::Placement> place_device(const cli::Args& args,
                                                             const rt::Device& device,
                                                             const Scene& scene, bool quiet) {
  const std::string_view kind = device.kind();  // for people only
  const bool placed = device.drives_a_hand();
  const bool asked = args.get("device-axes") || args.get("device-scale") ||
                     args.get("workspace-mm") ||
                     ((args.get("home") || args.get("home-clearance")) && !device.takes_home());
  if (!placed) {
    // A config file written for the lab's device may be tried with --device sim: a note, not
    // an error.
    if (asked)
      std::fprintf(stderr,
                   "palpd: note: the %s device moves in the scene frame: --home, --device-axes, "
                   "--device-scale and --workspace-mm are ignored (they place usb-haptic; "
                   "spacemouse takes --home)\n",
                   std::string(kind).c_str());
    return std::nullopt;
  }
  net::SceneDescription::Placement p;
  p.axes = args.get("device-axes").value_or("IAR");
  p.home_site = args.get("home").value_or("auto");
  p.workspace_half_mm = workspace_half(args.get("workspace-mm").value_or("50"));
  const double scale = args.number("device-scale", 1.0);
  if (!(scale >= 0.1 && scale <= 10.0)) throw UsageError("--device-scale must be 0.1..10");
  const PatientFrame frame = patient_frame(scene.grid);
  const HomeSite site =
      find_home_site(*scene.fields, p.home_site, args.number("home-clearance", 20.0));
  p.registration.rotation = rotation_from_axes(frame, p.axes);
  p.registration.scale = scale;
  p.registration.home = site.home;
  p.home_skin = site.skin;
  const std::string reach =
      check_reach(p.registration, site.skin, site.normal, p.workspace_half_mm, 10.0);
  if (!reach.empty()) throw UsageError("device placement: " + reach);
  if (!quiet) {
    std::string named;
    for (std::size_t a = 0; a < 3; ++a) {
      Anatomy d{};
      parse_anatomy(p.axes.substr(a, 1), &d);
      named += std::string(a ? ", " : "") + "xyz"[a] + " " + to_string(d);
    }
    std::fprintf(stderr,
                 "palpd: device placed at home '%s': workspace centre (%.1f, %.1f, %.1f) mm "
                 "(scene), %.0f mm above the skin; axes %s (%s), scale %g, workspace "
                 "+-(%g, %g, %g) mm\n",
                 p.home_site.c_str(), site.home.x, site.home.y, site.home.z,
                 norm(site.home - site.skin), p.axes.c_str(), named.c_str(), scale,
                 p.workspace_half_mm.x, p.workspace_half_mm.y, p.workspace_half_mm.z);
  }
  return p;
}

}  // namespace palp::app
