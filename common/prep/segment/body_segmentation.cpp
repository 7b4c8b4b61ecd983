// The body mask (segment_body): threshold, table removal, patient parts, internal air filled.
#include "prep/segment/segmentation.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "base/parallel.hpp"
#include "prep/segment/components.hpp"
#include "prep/segment/segmentation_shared.hpp"
#include "prep/segment/slice_planes.hpp"
#include "prep/segment/table_removal.hpp"

namespace palp {
namespace segmentation {
namespace {

Mask threshold_above(const CtVolume& ct, double threshold_hu) {
  Mask mask(ct.grid, 0, "body mask");
  const std::int64_t n = static_cast<std::int64_t>(ct.size());
  const int limit = integer_floor(threshold_hu);
  parallel_for_chunks(n, 1 << 20, [&](std::int64_t b, std::int64_t e) {
    for (std::int64_t i = b; i < e; ++i) mask.data[i] = ct.data[i] > limit;
  });
  return mask;
}

void mark_cores(const PatientAxes& axes, double radius_mm, Mask& mask) {
  const Grid& g = mask.grid;
  const auto ru = static_cast<std::int64_t>(std::floor(radius_mm / g.spacing[axes.lateral]));
  const auto rv = static_cast<std::int64_t>(std::floor(radius_mm / g.spacing[axes.posterior]));
  parallel_for_chunks(g.dims[axes.slice], 2, [&](std::int64_t s0, std::int64_t s1) {
    PlaneScratch scratch;
    for (std::int64_t s = s0; s < s1; ++s)
      mark_plane_cores(axial_plane(g, axes, s), mask.data.data(), ru, rv, scratch);
  });
}

// Keeps the 3D parts (6-connected) that are large enough and hold a core voxel (value 2).
void keep_patient_parts(double min_part_ml, Mask& mask) {
  const Grid& g = mask.grid;
  const RunTable runs = extract_runs(mask, false);
  const RunLabels labels = label_runs(g, runs);
  const auto has_core =
      components_with(g, runs, labels, [&](std::size_t n) { return mask.data[n] == 2; });
  const double ml = voxel_ml(g);
  // The largest cored part is the patient and always stays, however small the scan.
  std::int64_t largest = -1;
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(labels.voxels.size()); ++c) {
    if (has_core[c] && (largest < 0 || labels.voxels[c] > labels.voxels[largest])) largest = c;
  }
  rewrite_runs(
      g, runs, labels,
      [&](std::int64_t c) {
        return has_core[c] &&
               (c == largest || static_cast<double>(labels.voxels[c]) * ml >= min_part_ml);
      },
      mask);
}

void fill_axial_holes(const PatientAxes& axes, Mask& mask) {
  const Grid& g = mask.grid;
  parallel_for_chunks(g.dims[axes.slice], 2, [&](std::int64_t s0, std::int64_t s1) {
    PlaneScratch scratch;
    for (std::int64_t s = s0; s < s1; ++s) {
      fill_plane_holes(
          axial_plane(g, axes, s), mask.data.data(), [](std::int64_t) { return true; }, scratch);
    }
  });
}

// The table lies behind a supine patient and in front of a prone one, and the patient's frame does
// not say which way gravity pointed: the bands are looked for from behind and from the front, each
// on the mask as it was, and what either finds is removed (the order of two passes on one mask
// would matter: from the front, the table's parts beside a supine patient are found first and
// the rest, from behind, no longer joins them). Returns the voxels removed.
std::uint64_t remove_tables(const PatientAxes& axes, const SegmentationParams& params, Mask& body) {
  Mask from_front = body;
  PatientAxes front = axes;
  front.posterior_increasing = !axes.posterior_increasing;
  std::uint64_t removed = remove_table(axes, params, body);
  remove_table(front, params, from_front);
  for (std::size_t n = 0; n < body.data.size(); ++n) {
    if (body.data[n] && !from_front.data[n]) {
      body.data[n] = 0;
      ++removed;
    }
  }
  return removed;
}

}  // namespace
}  // namespace segmentation

Mask segment_body(const CtVolume& ct, const SegmentationParams& params, SegmentationStats* stats) {
  using namespace segmentation;
  check_params(params);
  const PatientAxes axes = patient_axes(ct.grid);
  Mask body = threshold_above(ct, params.body_threshold_hu);  // not air
  const std::uint64_t above = count_nonzero(body);
  const std::uint64_t table = remove_tables(axes, params, body);  // table, pad, cables
  mark_cores(axes, params.body_core_radius_mm, body);             // voxels deep inside
  keep_patient_parts(params.min_body_part_ml, body);              // large parts with a core
  const std::uint64_t kept_above = count_nonzero(body);
  fill_axial_holes(axes, body);  // internal air, per slice
  if (stats) {
    stats->body_voxels = count_nonzero(body);
    stats->removed_non_patient_voxels = above - kept_above;
    stats->table_voxels = table;
  }
  return body;
}

}  // namespace palp
