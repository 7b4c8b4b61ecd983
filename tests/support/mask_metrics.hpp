// Overlap and surface-distance measures of two masks on one grid, for segmentation tests: Dice,
// the mean symmetric surface distance, voxel counts. Plain loops (no library code under test).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "base/volume.hpp"

namespace palp::testing {

inline std::int64_t count(const Mask& m) {
  return std::count_if(m.data.begin(), m.data.end(), [](std::uint8_t v) { return v != 0; });
}

// Voxels where `a` is set and `b` is not.
inline std::int64_t count_and_not(const Mask& a, const Mask& b) {
  std::int64_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += a.data[i] && !b.data[i];
  return n;
}

inline std::int64_t count_both(const Mask& a, const Mask& b) {
  std::int64_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += a.data[i] && b.data[i];
  return n;
}

inline double dice(const Mask& a, const Mask& b) {
  return 2.0 * static_cast<double>(count_both(a, b)) / static_cast<double>(count(a) + count(b));
}

// Voxels of `m` with a face neighbour outside it (or on the grid's border).
inline Mask surface(const Mask& m) {
  const Grid& g = m.grid;
  Mask s(g, 0, "surface");
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        if (!m.at(i, j, k)) continue;
        const Index3 next[6] = {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k},
                                {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}};
        for (const Index3& q : next)
          if (!g.contains(q[0], q[1], q[2]) || !m.at(q[0], q[1], q[2])) s.at(i, j, k) = 1;
      }
  return s;
}

// Exact squared Euclidean distance (mm^2) from every voxel to the nearest voxel of `set`, with the
// grid's spacing: lower envelope of parabolas along each axis in turn.
inline std::vector<double> squared_distance_to(const Mask& set) {
  const Grid& g = set.grid;
  constexpr double kFar = std::numeric_limits<double>::infinity();
  std::vector<double> d(set.size());
  for (std::size_t n = 0; n < set.size(); ++n) d[n] = set.data[n] ? 0.0 : kFar;
  for (int axis = 0; axis < 3; ++axis) {
    const std::int64_t n = g.dims[axis];
    const double s = g.spacing[axis];
    const std::int64_t stride = axis == 0 ? 1 : axis == 1 ? g.dims[0] : g.dims[0] * g.dims[1];
    std::vector<double> f(n), z(n + 1);
    std::vector<std::int64_t> v(n);
    for (std::size_t start = 0; start < set.size(); ++start) {
      if ((static_cast<std::int64_t>(start) / stride) % n != 0) continue;  // first of its line
      for (std::int64_t q = 0; q < n; ++q) f[q] = d[start + q * stride];
      std::int64_t k = -1;
      for (std::int64_t q = 0; q < n; ++q) {
        if (f[q] == kFar) continue;
        double boundary = -kFar;
        while (k >= 0) {
          const std::int64_t p = v[k];
          boundary = ((f[q] + q * q * s * s) - (f[p] + p * p * s * s)) / (2.0 * s * (q - p));
          if (boundary > z[k]) break;
          --k;
        }
        ++k;
        v[k] = q;
        z[k] = k == 0 ? -kFar : boundary;
        z[k + 1] = kFar;
      }
      if (k < 0) continue;
      std::int64_t h = 0;
      for (std::int64_t q = 0; q < n; ++q) {
        while (z[h + 1] < q * s) ++h;
        const double dq = (q - v[h]) * s;
        d[start + q * stride] = dq * dq + f[v[h]];
      }
    }
  }
  return d;
}

// Mean symmetric distance (mm) between the surfaces of two masks.
// With `region` (same grid), only the surface voxels inside it are averaged; their distances are
// still to the whole of the other surface.
inline double mean_surface_distance(const Mask& a, const Mask& b, const Mask* region = nullptr) {
  const Mask sa = surface(a), sb = surface(b);
  const std::vector<double> to_a = squared_distance_to(sa), to_b = squared_distance_to(sb);
  double sum = 0.0;
  std::int64_t n = 0;
  for (std::size_t i = 0; i < sa.size(); ++i) {
    if (region && !region->data[i]) continue;
    if (sa.data[i]) sum += std::sqrt(to_b[i]), ++n;
    if (sb.data[i]) sum += std::sqrt(to_a[i]), ++n;
  }
  return sum / static_cast<double>(n);
}

// Dice counted only inside `region` (same grid).
inline double dice_within(const Mask& a, const Mask& b, const Mask& region) {
  std::int64_t both = 0, total = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!region.data[i]) continue;
    both += a.data[i] && b.data[i];
    total += (a.data[i] != 0) + (b.data[i] != 0);
  }
  return 2.0 * static_cast<double>(both) / static_cast<double>(total);
}

}  // namespace palp::testing
