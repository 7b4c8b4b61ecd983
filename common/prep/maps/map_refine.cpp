// Maps on a refined, aligned grid (see map_refine.hpp).
#include "prep/maps/map_refine.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "base/errors.hpp"
#include "base/parallel.hpp"

namespace palp {
namespace {

constexpr int kMaxFactor = 8;

std::int64_t refined_dim(std::int64_t n, int k) {
  return n > 1 ? (n - 1) * k + 1 : n;
}

std::size_t refined_count(const Grid& grid, const Refinement& k) {
  std::size_t count = 1;
  for (int a = 0; a < 3; ++a) count *= static_cast<std::size_t>(refined_dim(grid.dims[a], k[a]));
  return count;
}

// Per fine index along one axis: the coarse cell's lower node and the fraction within it.
struct AxisWeights {
  std::vector<std::int64_t> lo;
  std::vector<double> t;
};

AxisWeights axis_weights(std::int64_t n, int k) {
  AxisWeights w;
  const std::int64_t fine = refined_dim(n, k);
  w.lo.resize(static_cast<std::size_t>(fine));
  w.t.resize(static_cast<std::size_t>(fine));
  for (std::int64_t i = 0; i < fine; ++i) {
    const std::int64_t c = n > 1 ? std::min(i / k, n - 2) : 0;
    w.lo[static_cast<std::size_t>(i)] = c;
    w.t[static_cast<std::size_t>(i)] = n > 1 ? static_cast<double>(i - c * k) / k : 0.0;
  }
  return w;
}

}  // namespace

Refinement map_refinement(const Grid& grid, double map_spacing_mm) {
  Refinement k{1, 1, 1};
  if (!(map_spacing_mm > 0.0)) return k;
  for (int a = 0; a < 3; ++a) {
    if (grid.dims[a] < 2) continue;
    const double ratio = grid.spacing[a] / map_spacing_mm;
    // 1e-9: a spacing equal to the limit up to its decimal rounding is not refined.
    k[a] = static_cast<int>(std::clamp(std::ceil(ratio - 1e-9), 1.0, double{kMaxFactor}));
  }
  // Within the cap: lower the factor of the axis whose refined spacing is finest first.
  while (is_refined(k) && refined_count(grid, k) > kMaxRefinedVoxels) {
    int finest = -1;
    for (int a = 0; a < 3; ++a)
      if (k[a] > 1 && (finest < 0 || grid.spacing[a] / k[a] < grid.spacing[finest] / k[finest]))
        finest = a;
    --k[finest];
  }
  return k;
}

bool is_refined(const Refinement& k) {
  return k[0] > 1 || k[1] > 1 || k[2] > 1;
}

Grid refined_grid(const Grid& grid, const Refinement& k) {
  Grid fine = grid;
  for (int a = 0; a < 3; ++a) {
    if (k[a] < 1) throw UsageError("map refinement: a factor below 1");
    fine.dims[a] = refined_dim(grid.dims[a], k[a]);
    fine.spacing[a] = grid.spacing[a] / k[a];
  }
  return fine;
}

Refinement refinement_between(const Grid& coarse, const Grid& fine) {
  constexpr Refinement kNone{0, 0, 0};
  // The placement as read back from two files: equal up to their rounding.
  for (int a = 0; a < 3; ++a)
    if (!(std::abs(coarse.world.origin[a] - fine.world.origin[a]) <= 1e-4)) return kNone;
  for (std::size_t e = 0; e < 9; ++e)
    if (!(std::abs(coarse.world.direction[e] - fine.world.direction[e]) <= 1e-6)) return kNone;
  Refinement k{1, 1, 1};
  for (int a = 0; a < 3; ++a) {
    const std::int64_t n = coarse.dims[a];
    if (n < 1 || fine.dims[a] < 1) return kNone;
    if (n > 1) {
      if ((fine.dims[a] - 1) % (n - 1) != 0) return kNone;
      k[a] = static_cast<int>((fine.dims[a] - 1) / (n - 1));
    } else if (fine.dims[a] != 1) {
      return kNone;
    }
    const double expect = coarse.spacing[a] / k[a];
    if (!(std::abs(fine.spacing[a] - expect) <= 1e-6 * expect)) return kNone;
  }
  return k;
}

DistanceMap upsample_aligned(const DistanceMap& map, const Refinement& k, unsigned threads) {
  const Grid& g = map.grid;
  if (map.data.size() != g.voxel_count())
    throw UsageError("map refinement: the map's data does not match its grid");
  DistanceMap out(refined_grid(g, k), 0.0f, "refined distance map");
  const AxisWeights wx = axis_weights(g.dims[0], k[0]), wy = axis_weights(g.dims[1], k[1]),
                    wz = axis_weights(g.dims[2], k[2]);
  const Index3 n = out.grid.dims;
  // Neighbour steps in the coarse map (0 along an axis of one node).
  const std::size_t sx = g.dims[0] > 1 ? 1 : 0;
  const std::size_t sy = g.dims[1] > 1 ? static_cast<std::size_t>(g.dims[0]) : 0;
  const std::size_t sz = g.dims[2] > 1 ? static_cast<std::size_t>(g.dims[0] * g.dims[1]) : 0;
  parallel_for_chunks(
      n[2], 1,
      [&](std::int64_t k0, std::int64_t k1) {
        for (std::int64_t kk = k0; kk < k1; ++kk) {
          const double tz = wz.t[static_cast<std::size_t>(kk)];
          for (std::int64_t j = 0; j < n[1]; ++j) {
            const double ty = wy.t[static_cast<std::size_t>(j)];
            float* row = &out.data[out.grid.linear(0, j, kk)];
            for (std::int64_t i = 0; i < n[0]; ++i) {
              const double tx = wx.t[static_cast<std::size_t>(i)];
              const float* p = &map.data[g.linear(wx.lo[static_cast<std::size_t>(i)],
                                                  wy.lo[static_cast<std::size_t>(j)],
                                                  wz.lo[static_cast<std::size_t>(kk)])];
              // The same order of operations as the sampler's trilinear: x, then y, then z.
              const double c0 = p[0], c1 = p[sx], c2 = p[sy], c3 = p[sx + sy];
              const double c4 = p[sz], c5 = p[sx + sz], c6 = p[sy + sz], c7 = p[sx + sy + sz];
              const double e00 = c0 + tx * (c1 - c0), e10 = c2 + tx * (c3 - c2);
              const double e01 = c4 + tx * (c5 - c4), e11 = c6 + tx * (c7 - c6);
              const double f0 = e00 + ty * (e10 - e00), f1 = e01 + ty * (e11 - e01);
              row[i] = static_cast<float>(f0 + tz * (f1 - f0));
            }
          }
        }
      },
      threads);
  return out;
}

}  // namespace palp
