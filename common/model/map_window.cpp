#include "model/map_window.hpp"

#include <algorithm>
#include <cmath>

#include "base/errors.hpp"

namespace palp {

MapWindow window_for_box(const Grid& grid, const Vec3d& box_lo, const Vec3d& box_hi) {
  const double lo[3] = {box_lo.x, box_lo.y, box_lo.z};
  const double hi[3] = {box_hi.x, box_hi.y, box_hi.z};
  MapWindow w;
  double origin[3];
  for (int a = 0; a < 3; ++a) {
    if (!(std::isfinite(lo[a]) && std::isfinite(hi[a]) && lo[a] <= hi[a]))
      throw UsageError("map window: not a box");
    const double s = grid.spacing[a];
    const std::int64_t n = grid.dims[a];
    // The cells holding lo and hi, and their far corners.
    const auto first = static_cast<std::int64_t>(std::floor(lo[a] / s)) - 1;
    const auto last = static_cast<std::int64_t>(std::floor(hi[a] / s)) + 2;
    const std::int64_t i0 = std::clamp<std::int64_t>(first, 0, n - 1);
    const std::int64_t i1 = std::clamp<std::int64_t>(last, 0, n - 1);
    if (last < 0 || first > n - 1) throw UsageError("map window: the box misses the maps");
    w.lo[a] = i0;
    w.dims[a] = i1 - i0 + 1;
    origin[a] = static_cast<double>(i0) * s;
  }
  w.origin = {origin[0], origin[1], origin[2]};
  return w;
}

DistanceMap crop(const DistanceMap& map, const MapWindow& w) {
  for (int a = 0; a < 3; ++a)
    if (w.lo[a] < 0 || w.dims[a] < 1 || w.lo[a] + w.dims[a] > map.grid.dims[a])
      throw UsageError("map window: outside the map's grid");
  Grid g = map.grid;
  g.dims = w.dims;
  // world = origin + direction * (spacing .* ijk): the window's voxel 0 is the map's voxel lo.
  for (int r = 0; r < 3; ++r) {
    double shift = 0.0;
    for (int c = 0; c < 3; ++c)
      shift += map.grid.world.direction[static_cast<std::size_t>(3 * r + c)] * map.grid.spacing[c] *
               static_cast<double>(w.lo[c]);
    g.world.origin[r] += shift;
  }
  DistanceMap out(g, 0.0f, "cropped distance map");
  for (std::int64_t k = 0; k < w.dims[2]; ++k)
    for (std::int64_t j = 0; j < w.dims[1]; ++j) {
      const float* src = &map.data[map.grid.linear(w.lo[0], w.lo[1] + j, w.lo[2] + k)];
      std::copy(src, src + w.dims[0], &out.data[g.linear(0, j, k)]);
    }
  return out;
}

std::shared_ptr<const FieldSampler> window_sampler(const DistanceMap& surf, const DistanceMap& bone,
                                                   const FieldSampler& whole,
                                                   const MapWindow& window, SamplerConfig config) {
  if (whole.grid().dims != surf.grid.dims || whole.grid().dims != bone.grid.dims)
    throw UsageError("map window: the whole sampler is not on these maps");
  auto out =
      std::make_shared<FieldSampler>(crop(surf, window), crop(bone, window), config, window.origin);
  whole.prepare_bone_beneath();
  if (const float* beneath = whole.bone_beneath_data()) {
    DistanceMap full(whole.grid(), 0.0f, "bone-beneath map");
    std::copy(beneath, beneath + full.data.size(), full.data.begin());
    out->adopt_bone_beneath(std::move(crop(full, window).data));
  }
  return out;
}

}  // namespace palp
