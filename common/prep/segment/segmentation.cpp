// Patient axes, and the parameter checks and HU limits body and bone segmentation share.
#include "prep/segment/segmentation.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "base/errors.hpp"
#include "prep/segment/segmentation_shared.hpp"

namespace palp {
namespace segmentation {

void check_params(const SegmentationParams& p) {
  const double values[] = {p.body_threshold_hu,
                           p.min_body_part_ml,
                           p.body_core_radius_mm,
                           p.max_table_thickness_mm,
                           p.min_table_width_mm,
                           p.bone_seed_hu,
                           p.bone_grow_hu,
                           p.bone_leak_contact_fraction,
                           p.bone_max_hole_mm2,
                           p.bone_edge_fraction,
                           p.bone_max_cavity_ml,
                           p.min_bone_island_ml,
                           p.bone_enclosure_radius_mm,
                           p.bone_plate_radius_mm,
                           p.bone_calculus_max_length_mm,
                           p.bone_skin_clearance_mm,
                           p.bone_lumen_cortex_margin_hu,
                           p.bone_lumen_max_contact,
                           p.bone_lumen_radius_mm,
                           p.bone_rib_depth_mm};
  for (double v : values)
    if (!std::isfinite(v)) throw UsageError("segmentation: parameters must be finite numbers");
  if (p.min_body_part_ml < 0 || p.body_core_radius_mm < 0 || p.max_table_thickness_mm < 0 ||
      p.min_table_width_mm < 0 || p.bone_leak_contact_fraction < 0 || p.bone_max_hole_mm2 < 0 ||
      p.bone_max_cavity_ml < 0 || p.min_bone_island_ml < 0)
    throw UsageError("segmentation: sizes, radii and fractions must not be negative");
  if (p.bone_edge_fraction < 0 || p.bone_edge_fraction > 1)
    throw UsageError("segmentation: bone_edge_fraction must lie in [0, 1]");
  if (p.bone_marrow_votes < 1 || p.bone_marrow_votes > 3)
    throw UsageError("segmentation: bone_marrow_votes must be 1, 2 or 3");
  if (p.bone_enclosure_directions < 0 || p.bone_enclosure_directions > 13)
    throw UsageError("segmentation: bone_enclosure_directions must lie in [0, 13]");
  if (p.bone_enclosure_radius_mm < 0 || p.bone_enclosure_radius_mm > 100)
    throw UsageError("segmentation: bone_enclosure_radius_mm must lie in [0, 100]");
  if (p.bone_plate_radius_mm < 0 || p.bone_plate_radius_mm > 100)
    throw UsageError("segmentation: bone_plate_radius_mm must lie in [0, 100]");
  if (p.bone_calculus_max_length_mm < 0 || p.bone_calculus_max_length_mm > 200)
    throw UsageError("segmentation: bone_calculus_max_length_mm must lie in [0, 200]");
  if (p.bone_rib_depth_mm < 0 || p.bone_rib_depth_mm > 200)
    throw UsageError("segmentation: bone_rib_depth_mm must lie in [0, 200]");
  if (p.bone_skin_clearance_mm < 0 || p.bone_skin_clearance_mm > 20)
    throw UsageError("segmentation: bone_skin_clearance_mm must lie in [0, 20]");
  if (p.bone_lumen_cortex_margin_hu < 0 || p.bone_lumen_max_contact < 0 ||
      p.bone_lumen_max_contact > 1 || p.bone_lumen_radius_mm < 0 || p.bone_lumen_radius_mm > 100)
    throw UsageError(
        "segmentation: bone_lumen_cortex_margin_hu must not be negative, bone_lumen_max_contact "
        "must lie in [0, 1] and bone_lumen_radius_mm in [0, 100]");
  if (p.bone_notch_faces != 0 && (p.bone_notch_faces < 4 || p.bone_notch_faces > 6))
    throw UsageError("segmentation: bone_notch_faces must be 0 (off), 4, 5 or 6");
  if (p.bone_grow_hu > p.bone_seed_hu)
    throw UsageError("segmentation: bone_grow_hu must not exceed bone_seed_hu");
}

int integer_floor(double hu) {
  return static_cast<int>(std::clamp(std::floor(hu), -40000.0, 40000.0));
}

}  // namespace segmentation

PatientAxes patient_axes(const Grid& grid) {
  const auto& d = grid.world.direction;  // row-major; column a is index axis a
  const auto component = [&](int row, int axis) {
    return d[static_cast<std::size_t>(row * 3 + axis)];
  };
  PatientAxes axes;
  int slice = 0;
  for (int a = 1; a < 3; ++a)
    if (std::abs(component(2, a)) > std::abs(component(2, slice))) slice = a;
  if (std::abs(component(2, slice)) < 0.5) return axes;  // no usable direction: i, j, k
  int posterior = slice == 0 ? 1 : 0;
  for (int a = 0; a < 3; ++a)
    if (a != slice && std::abs(component(1, a)) > std::abs(component(1, posterior))) posterior = a;
  axes.slice = slice;
  axes.posterior = posterior;
  axes.lateral = 3 - slice - posterior;
  axes.posterior_increasing = component(1, posterior) > 0.0;
  return axes;
}

}  // namespace palp
