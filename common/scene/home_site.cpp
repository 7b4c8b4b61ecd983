// Named home sites on the skin: see home_site.hpp.
#include "scene/home_site.hpp"

#include <charconv>
#include <cmath>

#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "scene/trajectory_gen.hpp"

namespace palp {
namespace {

bool parse_point(std::string_view text, Vec3d* out) {
  double v[3];
  std::size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = i < 2 ? text.find(',', start) : text.size();
    if (comma == std::string_view::npos) return false;
    const std::string_view part = text.substr(start, comma - start);
    const auto [end, ec] = std::from_chars(part.data(), part.data() + part.size(), v[i]);
    if (part.empty() || ec != std::errc() || end != part.data() + part.size() ||
        !std::isfinite(v[i]))
      return false;
    start = comma + 1;
  }
  *out = {v[0], v[1], v[2]};
  return true;
}

// The skin point nearest to x along the distance map's gradient (a few Newton steps).
void project_to_skin(const FieldSampler& fields, Vec3d x, HomeSite* site) {
  for (int i = 0; i < 20; ++i) {
    const FieldSample s = fields.sample_surf(x);
    const double g = norm(s.grad);
    if (!(g > 1e-9)) throw InputError("home point: no skin surface near it in the scene");
    x = x - s.grad * (s.value / (g * g));  // D = 0 along the gradient
    if (std::fabs(s.value) < 1e-3) break;
  }
  const FieldSample s = fields.sample_surf(x);
  const double g = norm(s.grad);
  if (!(g > 1e-9) || std::fabs(s.value) > 0.5)
    throw InputError("home point: could not place it on the skin (is it within the band?)");
  site->skin = x;
  site->normal = s.grad * (-1.0 / g);
}

}  // namespace

HomeSite find_home_site(const FieldSampler& fields, std::string_view name, double clearance_mm) {
  if (!(clearance_mm >= 0.0 && clearance_mm <= 500.0))
    throw UsageError("home clearance must be 0..500 mm");
  HomeSite site;
  site.name = std::string(name);
  Vec3d point{};
  if (name == "ribs-right" || name == "ribs-left") {
    RibsSpec spec;
    spec.side = name == "ribs-right" ? BodySide::Right : BodySide::Left;
    const BodyAxis axis = ribs_body_axis(fields, spec);
    const SkinFrame frame = ribs_skin_frame(fields, axis, 0.5 * (spec.from + spec.to));
    site.skin = frame.skin;
    site.normal = frame.normal;
  } else if (parse_point(name, &point)) {
    project_to_skin(fields, scene_of_world(fields.grid(), point), &site);
  } else {
    ApproachSide side = ApproachSide::Auto;
    try {
      side = parse_approach_side(name);
    } catch (const UsageError&) {
      throw UsageError("home '" + std::string(name) +
                       "': auto, anterior, posterior, left, right, superior, inferior, "
                       "ribs-right, ribs-left, or X,Y,Z in patient coordinates (LPS mm)");
    }
    const SurfaceAnchor anchor = find_surface_anchor(fields, side);
    site.skin = anchor.point;
    site.normal = anchor.normal;
  }
  site.home = site.skin + site.normal * clearance_mm;
  return site;
}

}  // namespace palp
