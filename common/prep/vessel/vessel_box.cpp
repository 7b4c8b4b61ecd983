// The vessel search's box and crops (see vessel_box.hpp).
#include "prep/vessel/vessel_box.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "base/errors.hpp"
#include "prep/segment/segmentation.hpp"
#include "prep/vessel/vessel_outline.hpp"

namespace palp {
namespace {

template <class T>
Volume<T> crop_volume(const Volume<T>& v, const segmentation::VoxelBox& box) {
  Grid g = v.grid;
  for (int a = 0; a < 3; ++a) g.dims[a] = box.hi[a] - box.lo[a];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      g.world.origin[r] += v.grid.world.direction[static_cast<std::size_t>(3 * r + c)] *
                           v.grid.spacing[c] * static_cast<double>(box.lo[c]);
  Volume<T> out(g, T{}, "vessel search crop");
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j) {
      const T* from = &v.data[v.grid.linear(box.lo[0], box.lo[1] + j, box.lo[2] + k)];
      std::copy(from, from + g.dims[0], &out.data[g.linear(0, j, k)]);
    }
  return out;
}

}  // namespace

segmentation::VoxelBox vessel_search_box(const CtVolume& ct, const Mask& body, double soft_peak_hu,
                                         const VesselParams& params) {
  const Grid& g = ct.grid;
  if (body.grid.dims != g.dims || body.size() != ct.size())
    throw UsageError("vessel_search_box: the body mask is not on the CT's grid");
  const long low_hu = std::lround(soft_peak_hu + params.min_contrast_hu);
  Mask bright(g, 0, "contrast level or brighter");
  const std::uint8_t* in_body = body.data.data();
  const std::int16_t* own = ct.data.data();
  std::uint8_t* to = bright.data.data();
  const std::size_t count = bright.size();
  for (std::size_t n = 0; n < count; ++n) to[n] = (in_body[n] != 0) & (own[n] >= low_hu);
  segmentation::VoxelBox box = segmentation::nonzero_box(bright, 0);
  if (box.hi[0] == 0) return box;
  const double reach_mm =
      std::max(params.marrow_enclosure_mm, params.outline_max_radius_mm + kOutlineCalciumMm);
  const int slice = patient_axes(g).slice;
  for (int a = 0; a < 3; ++a) {
    const auto margin = static_cast<std::int64_t>(std::ceil(reach_mm / g.spacing[a])) + 2;
    box.lo[a] = a == slice ? 0 : std::max<std::int64_t>(0, box.lo[a] - margin);
    box.hi[a] = a == slice ? g.dims[a] : std::min(g.dims[a], box.hi[a] + margin);
  }
  return box;
}

bool box_saves_a_tenth(const segmentation::VoxelBox& box, std::size_t voxels) {
  const std::int64_t kept = box.size(0) * box.size(1) * box.size(2);
  return kept > 0 && kept * 10 <= static_cast<std::int64_t>(voxels) * 9;
}

CtVolume crop(const CtVolume& v, const segmentation::VoxelBox& box) {
  return crop_volume(v, box);
}

Mask crop(const Mask& v, const segmentation::VoxelBox& box) {
  return crop_volume(v, box);
}

void paste(const Mask& part, const segmentation::VoxelBox& box, Mask& whole) {
  const Grid& c = part.grid;
  for (std::int64_t k = 0; k < c.dims[2]; ++k)
    for (std::int64_t j = 0; j < c.dims[1]; ++j) {
      const std::uint8_t* from = &part.data[c.linear(0, j, k)];
      std::copy(from, from + c.dims[0],
                &whole.data[whole.grid.linear(box.lo[0], box.lo[1] + j, box.lo[2] + k)]);
    }
}

}  // namespace palp
