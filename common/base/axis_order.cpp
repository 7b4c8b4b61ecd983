// Reordering a volume's axes by an orientation code: see axis_order.hpp.
#include "base/axis_order.hpp"

#include <string>

#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "base/vec.hpp"

namespace palp {

// Below this obliquity (degrees) a grid counts as axis-aligned (prep's kAxisAlignedToleranceDeg).
constexpr double kReorderObliquityDeg = 0.05;

AxisReorder axis_reorder(const Grid& g, std::string_view code) {
  const PatientFrame frame = patient_frame(g);
  if (frame.obliquity_deg() > kReorderObliquityDeg)
    throw InputError("cannot reorder the axes of an oblique volume");
  const auto bad = [&] {
    return UsageError("orientation '" + std::string(code) +
                      "': expected three letters from L/R, P/A, S/I, one of each pair (LPS, RAS)");
  };
  if (code.size() != 3) throw bad();
  AxisReorder r;
  std::array<bool, 3> used{false, false, false};
  for (std::size_t a = 0; a < 3; ++a) {
    Anatomy want{};
    if (!parse_anatomy(code.substr(a, 1), &want)) throw bad();
    int found = -1;
    for (int b = 0; b < 3; ++b) {
      const Anatomy has = frame.axis_direction(b);
      if (has == want || has == opposite(want)) found = b, r.reversed[a] = has != want;
    }
    if (found < 0 || used[static_cast<std::size_t>(found)]) throw bad();
    used[static_cast<std::size_t>(found)] = true;
    r.source[a] = found;
  }
  Vec3 first_voxel{};  // scene position, in the source, of the new voxel (0, 0, 0)
  for (std::size_t a = 0; a < 3; ++a) {
    const auto b = static_cast<std::size_t>(r.source[a]);
    r.grid.dims[a] = g.dims[b];
    r.grid.spacing[a] = g.spacing[b];
    const double sign = r.reversed[a] ? -1.0 : 1.0;
    for (std::size_t row = 0; row < 3; ++row)
      r.grid.world.direction[3 * row + a] = g.world.direction[3 * row + b] * sign;
    if (r.reversed[a]) first_voxel[b] = static_cast<double>(g.dims[b] - 1) * g.spacing[b];
  }
  r.grid.world.origin = to_vec3(world_of_scene(g, to_vec3d(first_voxel)));
  return r;
}

}  // namespace palp
