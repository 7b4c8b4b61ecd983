// Resampling an oblique CT onto the nearest axis-aligned frame: see reorient.hpp.
#include "prep/reorient.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "base/axis_order.hpp"
#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "base/patient_frame.hpp"
#include "base/vec.hpp"

namespace palp {
namespace {

// Column a of the row-major direction.
Vec3d column(const std::array<double, 9>& d, int a) {
  return {d[static_cast<std::size_t>(a)], d[static_cast<std::size_t>(3 + a)],
          d[static_cast<std::size_t>(6 + a)]};
}

double comp(const Vec3d& v, int i) {
  return i == 0 ? v.x : i == 1 ? v.y : v.z;
}

// World (LPS) of the continuous index ijk.
Vec3d to_world(const Grid& g, const Vec3d& ijk) {
  return world_of_scene(g, {ijk.x * g.spacing[0], ijk.y * g.spacing[1], ijk.z * g.spacing[2]});
}

// Continuous index of a world point.
Vec3d to_index(const Grid& g, const Vec3d& w) {
  const Vec3d x = scene_of_world(g, w);
  return {x.x / g.spacing[0], x.y / g.spacing[1], x.z / g.spacing[2]};
}

}  // namespace

Grid axis_aligned_grid(const Grid& grid) {
  Grid out;
  out.spacing = grid.spacing;
  // Each index axis keeps the patient axis nearest to it, with the same sign.
  bool used[3] = {false, false, false};
  for (int a = 0; a < 3; ++a) {
    const Vec3d c = column(grid.world.direction, a);
    int best = 0;
    for (int r = 1; r < 3; ++r)
      if (std::fabs(comp(c, r)) > std::fabs(comp(c, best))) best = r;
    if (used[best] || std::fabs(comp(c, best)) <= std::sqrt(0.5) + 1e-12) {
      throw InputError(
          "the direction matrix is 45 degrees or more from every patient axis: no axis-aligned "
          "frame to resample onto");
    }
    used[best] = true;
    const double sign = comp(c, best) >= 0.0 ? 1.0 : -1.0;
    for (int r = 0; r < 3; ++r)
      out.world.direction[static_cast<std::size_t>(r * 3 + a)] = r == best ? sign : 0.0;
  }
  // The box, in the new frame, around the eight corner voxel centres of the old grid.
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  Grid frame = out;  // new direction, origin at the world origin
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3d ijk{(corner & 1) ? static_cast<double>(grid.dims[0] - 1) : 0.0,
                    (corner & 2) ? static_cast<double>(grid.dims[1] - 1) : 0.0,
                    (corner & 4) ? static_cast<double>(grid.dims[2] - 1) : 0.0};
    const Vec3d p = to_index(frame, to_world(grid, ijk));
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  for (int a = 0; a < 3; ++a) {
    const double first = std::floor(comp(lo, a) + 1e-6);
    out.dims[static_cast<std::size_t>(a)] =
        static_cast<std::int64_t>(std::ceil(comp(hi, a) - 1e-6) - first) + 1;
    if (a == 0) lo.x = first;
    if (a == 1) lo.y = first;
    if (a == 2) lo.z = first;
  }
  out.world.origin = to_vec3(to_world(frame, lo));
  validate_grid(out, "the axis-aligned grid of an oblique CT");
  const double growth =
      static_cast<double>(out.voxel_count()) / static_cast<double>(grid.voxel_count());
  if (growth > kMaxReorientGrowth) {
    std::ostringstream msg;
    msg << "resampling the oblique CT onto an axis-aligned grid would grow it " << growth
        << " times (at most " << kMaxReorientGrowth << ")";
    throw InputError(msg.str());
  }
  return out;
}

CtVolume resample_axis_aligned(const CtVolume& ct) {
  return resample(ct, axis_aligned_grid(ct.grid));
}

CtVolume resample(const CtVolume& ct, const Grid& g) {
  CtVolume out(g, std::int16_t{-1000}, "resampled CT");
  const Grid& src = ct.grid;
  // Index in the source = A·ijk' + b: affine, so one step per new index axis.
  const Vec3d b = to_index(src, to_world(g, {0, 0, 0}));
  const Vec3d di = to_index(src, to_world(g, {1, 0, 0})) - b;
  const Vec3d dj = to_index(src, to_world(g, {0, 1, 0})) - b;
  const Vec3d dk = to_index(src, to_world(g, {0, 0, 1})) - b;
  const double nx = static_cast<double>(src.dims[0] - 1), ny = static_cast<double>(src.dims[1] - 1),
               nz = static_cast<double>(src.dims[2] - 1);
  parallel_for_chunks(g.dims[2], 1, [&](std::int64_t k_begin, std::int64_t k_end) {
    for (std::int64_t k = k_begin; k < k_end; ++k)
      for (std::int64_t j = 0; j < g.dims[1]; ++j) {
        const Vec3d row = b + dj * static_cast<double>(j) + dk * static_cast<double>(k);
        for (std::int64_t i = 0; i < g.dims[0]; ++i) {
          const Vec3d p = row + di * static_cast<double>(i);
          if (!(p.x >= -1e-9 && p.y >= -1e-9 && p.z >= -1e-9 && p.x <= nx + 1e-9 &&
                p.y <= ny + 1e-9 && p.z <= nz + 1e-9))
            continue;  // outside the scanned volume: air
          const double fx = std::clamp(p.x, 0.0, nx), fy = std::clamp(p.y, 0.0, ny),
                       fz = std::clamp(p.z, 0.0, nz);
          const std::int64_t x0 = std::min(static_cast<std::int64_t>(fx), src.dims[0] - 1);
          const std::int64_t y0 = std::min(static_cast<std::int64_t>(fy), src.dims[1] - 1);
          const std::int64_t z0 = std::min(static_cast<std::int64_t>(fz), src.dims[2] - 1);
          const std::int64_t x1 = std::min(x0 + 1, src.dims[0] - 1);
          const std::int64_t y1 = std::min(y0 + 1, src.dims[1] - 1);
          const std::int64_t z1 = std::min(z0 + 1, src.dims[2] - 1);
          const double tx = fx - static_cast<double>(x0), ty = fy - static_cast<double>(y0),
                       tz = fz - static_cast<double>(z0);
          const auto v = [&](std::int64_t x, std::int64_t y, std::int64_t z) {
            return static_cast<double>(ct.at(x, y, z));
          };
          const double c00 = v(x0, y0, z0) * (1 - tx) + v(x1, y0, z0) * tx;
          const double c10 = v(x0, y1, z0) * (1 - tx) + v(x1, y1, z0) * tx;
          const double c01 = v(x0, y0, z1) * (1 - tx) + v(x1, y0, z1) * tx;
          const double c11 = v(x0, y1, z1) * (1 - tx) + v(x1, y1, z1) * tx;
          const double c0 = c00 * (1 - ty) + c10 * ty, c1 = c01 * (1 - ty) + c11 * ty;
          const double value = std::round(c0 * (1 - tz) + c1 * tz);
          out.at(i, j, k) = static_cast<std::int16_t>(std::clamp(value, -32768.0, 32767.0));
        }
      }
  });
  return out;
}

CtVolume reorder_axes(const CtVolume& ct, std::string_view code) {
  static_assert(kAxisAlignedToleranceDeg == 0.05, "axis_reorder's tolerance follows it");
  return reorder_volume(ct, axis_reorder(ct.grid, code), "reordered CT");
}

}  // namespace palp
