// Closest-point projection onto the trilinear HU iso-surface (see iso_projection.hpp).
//
// Slices are projected in parallel; each reads the map as the sub-voxel stage left it and keeps
// its new values apart, so no node sees a neighbour already moved. They are written at the end.
#include "prep/iso_projection.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "prep/map_refine.hpp"

namespace palp {
namespace {

constexpr int kMaxIterations = 24;
constexpr int kNewtonSteps = 4;
constexpr double kOnSurface = 5e-3;  // mm: |HU - iso| / |grad HU| on the level set
constexpr double kTangent = 0.05;    // mm: the last tangent move (see closest_point)

struct Sample {
  double f;     // HU - iso, trilinear
  double g[3];  // its gradient, HU per mm (the cell's own: it jumps across cell faces)
  std::int64_t cell[3];
};

class Trilinear {
 public:
  Trilinear(const CtVolume& ct, double iso) : ct_(ct), iso_(iso) {}

  Sample at(const double x[3]) const {
    const Grid& grid = ct_.grid;
    Sample s{};
    double t[3];
    for (int a = 0; a < 3; ++a) {
      const double top = static_cast<double>(grid.dims[a] - 1);
      const double u = std::clamp(x[a] / grid.spacing[a], 0.0, top);
      s.cell[a] = std::min(static_cast<std::int64_t>(u), grid.dims[a] - 2);
      t[a] = u - static_cast<double>(s.cell[a]);
    }
    const std::int16_t* p = &ct_.data[grid.linear(s.cell[0], s.cell[1], s.cell[2])];
    const std::size_t sy = static_cast<std::size_t>(grid.dims[0]);
    const std::size_t sz = sy * static_cast<std::size_t>(grid.dims[1]);
    const double c[8] = {static_cast<double>(p[0]),       static_cast<double>(p[1]),
                         static_cast<double>(p[sy]),      static_cast<double>(p[sy + 1]),
                         static_cast<double>(p[sz]),      static_cast<double>(p[sz + 1]),
                         static_cast<double>(p[sz + sy]), static_cast<double>(p[sz + sy + 1])};
    const double x0 = 1.0 - t[0], y0 = 1.0 - t[1], z0 = 1.0 - t[2];
    // Along x at the four (y, z) corners, then y, then z.
    const double e00 = x0 * c[0] + t[0] * c[1], e10 = x0 * c[2] + t[0] * c[3];
    const double e01 = x0 * c[4] + t[0] * c[5], e11 = x0 * c[6] + t[0] * c[7];
    const double f0 = y0 * e00 + t[1] * e10, f1 = y0 * e01 + t[1] * e11;
    s.f = z0 * f0 + t[2] * f1 - iso_;
    const double dx = z0 * (y0 * (c[1] - c[0]) + t[1] * (c[3] - c[2])) +
                      t[2] * (y0 * (c[5] - c[4]) + t[1] * (c[7] - c[6]));
    const double dy = z0 * (e10 - e00) + t[2] * (e11 - e01);
    const double dz = f1 - f0;
    s.g[0] = dx / grid.spacing[0];
    s.g[1] = dy / grid.spacing[1];
    s.g[2] = dz / grid.spacing[2];
    return s;
  }

 private:
  const CtVolume& ct_;
  double iso_;
};

double dot(const double a[3], const double b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// Newton steps of x onto the level set along the gradient until within kOnSurface of it;
// false where the HU are flat or it does not get there in a few steps. `s` ends as the sample
// at x.
bool onto_level_set(const Trilinear& hu, double x[3], Sample& s) {
  for (int step = 0;; ++step) {
    s = hu.at(x);
    const double g2 = dot(s.g, s.g);
    if (!(g2 > 1e-12)) return false;
    if (s.f * s.f <= kOnSurface * kOnSurface * g2) return true;  // |f| / |g|: mm, first order
    if (step == kNewtonSteps) return false;
    const double scale = s.f / g2;
    for (int a = 0; a < 3; ++a) x[a] -= scale * s.g[a];
  }
}

double distance(const double q[3], const double x[3]) {
  const double r[3] = {q[0] - x[0], q[1] - x[1], q[2] - x[2]};
  return std::sqrt(dot(r, r));
}

// The nearest point to q on the level set, from the start x: a descent on |q - x| over the
// surface. Each step moves x along its tangent plane towards q's foot on it and back onto the
// level set, and is kept only if it brings x nearer q (else halved). The trilinear HU's gradient
// jumps across cell faces, so the nearest point may sit on a crease where no tangent plane
// satisfies the closest-point condition; the descent still settles there. Every x kept lies on
// the surface (within kOnSurface), so the distance returned is never below the true one by
// more than that; it stops once the tangent move is below kTangent, where the distance is off
// by at most kTangent^2 / (2 |q - x|) beyond it. Negative where x cannot be put on the level set.
double closest_point(const Trilinear& hu, const double q[3], double x[3]) {
  Sample s;
  if (!onto_level_set(hu, x, s)) return -1.0;
  double best = distance(q, x);
  double step = 1.0;
  for (int it = 0; it < kMaxIterations; ++it) {
    const double g = std::sqrt(dot(s.g, s.g));
    const double n[3] = {s.g[0] / g, s.g[1] / g, s.g[2] / g};
    const double r[3] = {q[0] - x[0], q[1] - x[1], q[2] - x[2]};
    const double along = dot(r, n);
    double t[3], t2 = 0.0;
    for (int a = 0; a < 3; ++a) {
      t[a] = r[a] - along * n[a];
      t2 += t[a] * t[a];
    }
    if (t2 * step * step < kTangent * kTangent) break;
    double y[3] = {x[0] + step * t[0], x[1] + step * t[1], x[2] + step * t[2]};
    Sample sy;
    const double dy = onto_level_set(hu, y, sy) ? distance(q, y) : best;
    if (dy < best) {
      x[0] = y[0], x[1] = y[1], x[2] = y[2];
      s = sy;
      best = dy;
      step = std::min(1.0, 2.0 * step);
    } else {
      step *= 0.5;
    }
  }
  return best;
}

// Whether the mask changes across the cell with lower corner `cell`.
bool cell_cut_by_mask(const Mask& mask, const std::int64_t cell[3]) {
  bool in = false, out = false;
  for (int v = 0; v < 8; ++v) {
    const bool m = mask.at(cell[0] + (v & 1), cell[1] + ((v >> 1) & 1), cell[2] + (v >> 2)) != 0;
    in = in || m;
    out = out || !m;
  }
  return in && out;
}

// The map's gradient at a node by central differences (one-sided at the grid's faces).
bool map_gradient(const DistanceMap& map, std::int64_t i, std::int64_t j, std::int64_t k,
                  double n[3]) {
  const Grid& grid = map.grid;
  const std::int64_t at[3] = {i, j, k};
  for (int a = 0; a < 3; ++a) {
    std::int64_t lo[3] = {i, j, k}, hi[3] = {i, j, k};
    if (at[a] > 0) --lo[a];
    if (at[a] + 1 < grid.dims[a]) ++hi[a];
    const double span = static_cast<double>(hi[a] - lo[a]) * grid.spacing[a];
    n[a] = span > 0.0 ? (map.at(hi[0], hi[1], hi[2]) - map.at(lo[0], lo[1], lo[2])) / span : 0.0;
  }
  const double norm = std::sqrt(dot(n, n));
  if (!(norm > 0.5)) return false;  // a ridge or a kink of the map: no foot point to start from
  for (int a = 0; a < 3; ++a) n[a] /= norm;
  return true;
}

}  // namespace

double distance_to_iso_surface(const CtVolume& ct, double iso_hu, const double q[3],
                               double start[3]) {
  for (int a = 0; a < 3; ++a)
    if (ct.grid.dims[a] < 2) throw UsageError("iso-surface distance: the CT is too small");
  return closest_point(Trilinear(ct, iso_hu), q, start);
}

IsoProjectionStats project_onto_iso_surface(const CtVolume& ct, const Mask& mask, double iso_hu,
                                            double reach_mm, double outside_mm,
                                            double max_change_mm, double clamp_mm, DistanceMap& map,
                                            unsigned threads) {
  const Grid& grid = map.grid;
  // The map lies on the CT's grid or on its aligned refinement (prep/map_refine.hpp).
  const Refinement refine = refinement_between(ct.grid, grid);
  if (refine[0] == 0 || mask.grid.dims != ct.grid.dims || ct.data.size() != ct.grid.voxel_count() ||
      mask.data.size() != ct.grid.voxel_count() || map.data.size() != grid.voxel_count()) {
    throw UsageError("iso-surface projection: the CT, the mask and the map differ in grid");
  }
  IsoProjectionStats stats;
  if (!(reach_mm > 0.0)) return stats;
  for (int a = 0; a < 3; ++a)
    if (grid.dims[a] < 2) return stats;
  if (threads == 0) threads = default_thread_count();
  const Trilinear hu(ct, iso_hu);
  const Index3 n = grid.dims;
  const float clamp = static_cast<float>(clamp_mm);
  constexpr float kSteps = 1024.0f;
  using Update = std::pair<std::size_t, float>;
  std::vector<std::vector<Update>> updates(static_cast<std::size_t>(n[2]));
  std::vector<std::size_t> visited(static_cast<std::size_t>(n[2]), 0);
  parallel_for_chunks(
      n[2], 1,
      [&](std::int64_t k0, std::int64_t k1) {
        for (std::int64_t k = k0; k < k1; ++k) {
          auto& out = updates[static_cast<std::size_t>(k)];
          std::size_t seen = 0;
          for (std::int64_t j = 0; j < n[1]; ++j)
            for (std::int64_t i = 0; i < n[0]; ++i) {
              const std::size_t v = grid.linear(i, j, k);
              const double d = map.data[v];
              if (!(d <= reach_mm && d >= -outside_mm) || std::abs(d) >= clamp_mm) continue;
              ++seen;
              const double q[3] = {static_cast<double>(i) * grid.spacing[0],
                                   static_cast<double>(j) * grid.spacing[1],
                                   static_cast<double>(k) * grid.spacing[2]};
              bool inside;
              if (i % refine[0] == 0 && j % refine[1] == 0 && k % refine[2] == 0) {
                const std::size_t c = ct.grid.linear(i / refine[0], j / refine[1], k / refine[2]);
                inside = mask.data[c] != 0;
                if ((ct.data[c] - iso_hu >= 0.0) != inside) continue;  // the mask overrides the HU
              } else {
                // Between the CT's nodes: the upsampled map's sign, unless the cell is cut by
                // the mask, where the trilinear HU's own sign says which side the node is on.
                const Sample at_q = hu.at(q);
                inside = d > 0.0;
                if ((at_q.f >= 0.0) != inside) {
                  if (!cell_cut_by_mask(mask, at_q.cell)) continue;
                  inside = at_q.f >= 0.0;
                }
              }
              double nd[3];
              if (!map_gradient(map, i, j, k, nd)) continue;
              double x[3] = {q[0] - d * nd[0], q[1] - d * nd[1], q[2] - d * nd[2]};
              const double dist = closest_point(hu, q, x);
              if (!(dist >= 0.0)) continue;
              if (!cell_cut_by_mask(mask, hu.at(x).cell)) continue;
              if (std::abs(dist - std::abs(d)) > max_change_mm) continue;
              const float rounded =
                  std::min(clamp, std::nearbyint(static_cast<float>(dist) * kSteps) / kSteps);
              out.emplace_back(v, inside ? rounded : -rounded);
            }
          visited[static_cast<std::size_t>(k)] = seen;
        }
      },
      threads);
  for (std::size_t k = 0; k < updates.size(); ++k) {
    stats.visited += visited[k];
    stats.projected += updates[k].size();
    for (const auto& [v, value] : updates[k]) map.data[v] = value;
  }
  return stats;
}

IsoProjectionStats project_skin_map(const CtVolume& ct, const Mask& body, double skin_hu,
                                    double reach_mm, double clamp_mm, DistanceMap& map,
                                    unsigned threads) {
  const double coarsest = ct.grid.max_spacing();
  return project_onto_iso_surface(ct, body, skin_hu, reach_mm, coarsest, 0.25 * coarsest, clamp_mm,
                                  map, threads);
}

}  // namespace palp
