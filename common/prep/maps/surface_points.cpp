// Iso-surface points on the edges where a mask changes (see subvoxel_distance.hpp, "surface
// points"): placed by linear interpolation of HU along the edge, with the HU gradient's normal.
// Slices are scanned in parallel; each keeps its own points, joined in slice order.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "prep/maps/subvoxel_distance.hpp"

namespace palp {
namespace {

struct Gradient {
  double g[3];
};

// The HU gradient at a voxel (HU per mm) by the 3x3x3 Sobel operator: central differences
// along each axis, averaged across it with weights 1-2-1. It is far less biased towards the grid
// axes than plain central differences where a surface crosses the voxel obliquely, and averages
// noise. Neighbours off the grid repeat the border voxel.
Gradient hu_gradient(const CtVolume& ct, std::int64_t i, std::int64_t j, std::int64_t k) {
  const Grid& grid = ct.grid;
  auto clampi = [](std::int64_t v, std::int64_t n) {
    return std::clamp<std::int64_t>(v, 0, n - 1);
  };
  double sum[3] = {0.0, 0.0, 0.0};
  static constexpr double kWeight[3] = {1.0, 2.0, 1.0};
  for (int c = -1; c <= 1; ++c) {
    const std::int64_t kk = clampi(k + c, grid.dims[2]);
    for (int b = -1; b <= 1; ++b) {
      const std::int64_t jj = clampi(j + b, grid.dims[1]);
      for (int a = -1; a <= 1; ++a) {
        if (a == 0 && b == 0 && c == 0) continue;
        const std::int64_t ii = clampi(i + a, grid.dims[0]);
        const double hu = ct.at(ii, jj, kk);
        sum[0] += a * kWeight[b + 1] * kWeight[c + 1] * hu;
        sum[1] += b * kWeight[a + 1] * kWeight[c + 1] * hu;
        sum[2] += c * kWeight[a + 1] * kWeight[b + 1] * hu;
      }
    }
  }
  Gradient out{};
  for (int a = 0; a < 3; ++a) out.g[a] = sum[a] / (32.0 * grid.spacing[a]);
  return out;
}

// The point on the edge from voxel u (index at) to its neighbour along `axis`.
SurfacePoint edge_point(const CtVolume& ct, std::int64_t i, std::int64_t j, std::int64_t k,
                        int axis, double iso, bool* interpolated) {
  const Grid& grid = ct.grid;
  std::int64_t v[3] = {i, j, k};
  ++v[axis];
  const double hu_u = ct.at(i, j, k), hu_v = ct.at(v[0], v[1], v[2]);
  double t = 0.5;
  *interpolated = false;
  if ((hu_u - iso) * (hu_v - iso) <= 0.0 && hu_u != hu_v) {
    t = (iso - hu_u) / (hu_v - hu_u);
    *interpolated = true;
  }
  const Gradient gu = hu_gradient(ct, i, j, k), gv = hu_gradient(ct, v[0], v[1], v[2]);
  double n[3];
  double norm2 = 0.0;
  for (int a = 0; a < 3; ++a) {
    n[a] = (1.0 - t) * gu.g[a] + t * gv.g[a];
    norm2 += n[a] * n[a];
  }
  if (!(norm2 > 1e-12)) {  // flat HU: the edge's own direction
    n[0] = n[1] = n[2] = 0.0;
    n[axis] = 1.0;
    norm2 = 1.0;
  }
  const double inv = 1.0 / std::sqrt(norm2);
  double pos[3] = {static_cast<double>(i), static_cast<double>(j), static_cast<double>(k)};
  pos[axis] += t;
  SurfacePoint p;
  p.x = static_cast<float>(pos[0] * grid.spacing[0]);
  p.y = static_cast<float>(pos[1] * grid.spacing[1]);
  p.z = static_cast<float>(pos[2] * grid.spacing[2]);
  p.nx = static_cast<float>(n[0] * inv);
  p.ny = static_cast<float>(n[1] * inv);
  p.nz = static_cast<float>(n[2] * inv);
  p.i = static_cast<std::int32_t>(i);
  p.j = static_cast<std::int32_t>(j);
  p.k = static_cast<std::int32_t>(k);
  p.axis = static_cast<std::int32_t>(axis);
  p.t = static_cast<float>(t);
  return p;
}

}  // namespace

SurfacePoints surface_points(const CtVolume& ct, const Mask& mask, double iso_hu,
                             unsigned threads) {
  const Grid& grid = ct.grid;
  if (mask.grid.dims != grid.dims || mask.data.size() != grid.voxel_count()) {
    throw UsageError("surface points: the mask and the CT have different grids");
  }
  threads = thread_count_or_default(threads);
  const Index3 n = grid.dims;
  std::vector<std::vector<SurfacePoint>> per_slice(static_cast<std::size_t>(n[2]));
  std::vector<std::size_t> interpolated(static_cast<std::size_t>(n[2]), 0);
  parallel_for_chunks(
      n[2], 2,
      [&](std::int64_t k0, std::int64_t k1) {
        for (std::int64_t k = k0; k < k1; ++k) {
          auto& out = per_slice[static_cast<std::size_t>(k)];
          std::size_t placed = 0;
          for (std::int64_t j = 0; j < n[1]; ++j) {
            const std::uint8_t* row = &mask.data[grid.linear(0, j, k)];
            const std::uint8_t* next_row =
                j + 1 < n[1] ? &mask.data[grid.linear(0, j + 1, k)] : nullptr;
            const std::uint8_t* next_slice =
                k + 1 < n[2] ? &mask.data[grid.linear(0, j, k + 1)] : nullptr;
            for (std::int64_t i = 0; i < n[0]; ++i) {
              // Eight voxels at once where no edge can change (most of the grid): the same bytes
              // one voxel on, in the next row and in the next slice.
              if (next_row != nullptr && next_slice != nullptr && i + 9 <= n[0]) {
                std::uint64_t here, on, up, above;
                std::memcpy(&here, row + i, 8);
                std::memcpy(&on, row + i + 1, 8);
                std::memcpy(&up, next_row + i, 8);
                std::memcpy(&above, next_slice + i, 8);
                if (here == on && here == up && here == above) {
                  i += 7;
                  continue;
                }
              }
              const bool in = row[i] != 0;
              const bool differs[3] = {i + 1 < n[0] && (row[i + 1] != 0) != in,
                                       next_row && (next_row[i] != 0) != in,
                                       next_slice && (next_slice[i] != 0) != in};
              for (int axis = 0; axis < 3; ++axis) {
                if (!differs[axis]) continue;
                bool by_hu = false;
                out.push_back(edge_point(ct, i, j, k, axis, iso_hu, &by_hu));
                placed += by_hu;
              }
            }
          }
          interpolated[static_cast<std::size_t>(k)] = placed;
        }
      },
      threads);
  SurfacePoints result;
  result.grid = grid;
  result.slice_begin.assign(static_cast<std::size_t>(n[2]) + 1, 0);
  std::size_t total = 0;
  for (std::size_t k = 0; k < per_slice.size(); ++k) {
    result.slice_begin[k] = total;
    total += per_slice[k].size();
    result.interpolated += interpolated[k];
  }
  result.slice_begin.back() = total;
  result.points.reserve(total);
  for (auto& slice : per_slice) {
    result.points.insert(result.points.end(), slice.begin(), slice.end());
    slice = {};
  }
  return result;
}

}  // namespace palp
