// Closest-point projection onto the trilinear HU iso-surface (see iso_projection.hpp).
//
// Slices are projected in parallel; each reads the map as the sub-voxel stage left it and keeps
// its new values apart, so no node sees a neighbour already moved. They are written at the end.
//
// The descent runs in one canonical storage order whatever the grid's (`Order`, `View`): the same
// patient stored in another order (a NIfTI in RAS, a DICOM series in LPS) then takes the same
// floating-point path and settles on the same point near a crease, bit for bit. Computed in the
// storage order, the shared CT's d_surf differed by up to 0.37 mm at a few nodes between the two.
#include "prep/maps/iso_projection.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "base/patient_frame.hpp"
#include "prep/maps/map_refine.hpp"
#include "prep/maps/map_rounding.hpp"

namespace palp {
namespace {

constexpr int kMaxIterations = 24;
constexpr int kNewtonSteps = 4;
constexpr double kOnSurface = 5e-3;  // mm: |HU - iso| / |grad HU| on the level set
constexpr double kTangent = 0.05;    // mm: the last tangent move (see closest_point)

// Canonical axis d is the grid axis nearest the patient's left, posterior and superior in turn
// (base/patient_frame.hpp), pointing along it; the storage order itself where those do not name
// three different axes (a direction matrix at 45 degrees to them, or none usable).
struct Order {
  int axis[3] = {0, 1, 2};  // the storage axis of canonical axis d
  bool flip[3] = {false, false, false};
};

Order canonical_order(const Grid& grid) {
  const PatientFrame frame = patient_frame(grid);
  const Anatomy toward[3] = {Anatomy::Left, Anatomy::Posterior, Anatomy::Superior};
  Order o;
  bool used[3] = {false, false, false};
  for (int d = 0; d < 3; ++d) {
    const SignedAxis nearest = frame.nearest_axis(toward[d]);
    if (used[nearest.axis]) return Order{};
    used[nearest.axis] = true;
    o.axis[d] = nearest.axis;
    o.flip[d] = nearest.sign < 0;
  }
  return o;
}

// A grid seen in an Order: dims and spacing along the canonical axes, and where a canonical index
// lies in storage.
struct View {
  Index3 dims{};
  double spacing[3] = {1.0, 1.0, 1.0};
  std::int64_t stride[3] = {0, 0, 0};  // storage step of one canonical step (< 0 when flipped)
  std::int64_t base = 0;               // storage index of canonical (0, 0, 0)
  const Order* order = nullptr;
  const Grid* grid = nullptr;

  View(const Grid& g, const Order& o) : order(&o), grid(&g) {
    const std::int64_t storage[3] = {1, g.dims[0], g.dims[0] * g.dims[1]};
    for (int d = 0; d < 3; ++d) {
      const int a = o.axis[d];
      dims[d] = g.dims[a];
      spacing[d] = g.spacing[a];
      stride[d] = o.flip[d] ? -storage[a] : storage[a];
      if (o.flip[d]) base += (g.dims[a] - 1) * storage[a];
    }
  }
  std::size_t linear(std::int64_t i, std::int64_t j, std::int64_t k) const {
    return static_cast<std::size_t>(base + i * stride[0] + j * stride[1] + k * stride[2]);
  }
  // The canonical index of storage voxel (i, j, k).
  void canonical(std::int64_t i, std::int64_t j, std::int64_t k, std::int64_t c[3]) const {
    const std::int64_t s[3] = {i, j, k};
    for (int d = 0; d < 3; ++d) {
      const int a = order->axis[d];
      c[d] = order->flip[d] ? grid->dims[a] - 1 - s[a] : s[a];
    }
  }
};

struct Sample {
  double f;     // HU - iso, trilinear
  double g[3];  // its gradient, HU per mm (the cell's own: it jumps across cell faces)
  std::int64_t cell[3];
};

class Trilinear {
 public:
  // x in mm along `view`'s axes from its voxel (0, 0, 0).
  Trilinear(const CtVolume& ct, const View& view, double iso) : ct_(ct), view_(view), iso_(iso) {}

  Sample at(const double x[3]) const {
    const View& v = view_;
    Sample s{};
    double t[3];
    for (int a = 0; a < 3; ++a) {
      const double top = static_cast<double>(v.dims[a] - 1);
      const double u = std::clamp(x[a] / v.spacing[a], 0.0, top);
      s.cell[a] = std::min(static_cast<std::int64_t>(u), v.dims[a] - 2);
      t[a] = u - static_cast<double>(s.cell[a]);
    }
    const std::int16_t* p = &ct_.data[v.linear(s.cell[0], s.cell[1], s.cell[2])];
    const std::ptrdiff_t sx = v.stride[0], sy = v.stride[1], sz = v.stride[2];
    const double c[8] = {static_cast<double>(p[0]),       static_cast<double>(p[sx]),
                         static_cast<double>(p[sy]),      static_cast<double>(p[sy + sx]),
                         static_cast<double>(p[sz]),      static_cast<double>(p[sz + sx]),
                         static_cast<double>(p[sz + sy]), static_cast<double>(p[sz + sy + sx])};
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
    s.g[0] = dx / v.spacing[0];
    s.g[1] = dy / v.spacing[1];
    s.g[2] = dz / v.spacing[2];
    return s;
  }

 private:
  const CtVolume& ct_;
  const View& view_;
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

// Whether the mask changes across the cell with lower corner `cell` (canonical, in `view`).
bool cell_cut_by_mask(const Mask& mask, const View& view, const std::int64_t cell[3]) {
  bool in = false, out = false;
  for (int v = 0; v < 8; ++v) {
    const bool m =
        mask.data[view.linear(cell[0] + (v & 1), cell[1] + ((v >> 1) & 1), cell[2] + (v >> 2))] !=
        0;
    in = in || m;
    out = out || !m;
  }
  return in && out;
}

// The map's gradient at canonical node c by central differences (one-sided at the grid's
// faces), along `view`'s axes.
bool map_gradient(const DistanceMap& map, const View& view, const std::int64_t c[3], double n[3]) {
  for (int a = 0; a < 3; ++a) {
    std::int64_t lo[3] = {c[0], c[1], c[2]}, hi[3] = {c[0], c[1], c[2]};
    if (c[a] > 0) --lo[a];
    if (c[a] + 1 < view.dims[a]) ++hi[a];
    const double span = static_cast<double>(hi[a] - lo[a]) * view.spacing[a];
    n[a] = span > 0.0 ? (map.data[view.linear(hi[0], hi[1], hi[2])] -
                         map.data[view.linear(lo[0], lo[1], lo[2])]) /
                            span
                      : 0.0;
  }
  const double norm = std::sqrt(dot(n, n));
  if (!(norm > 0.5)) return false;  // a ridge or a kink of the map: no foot point to start from
  for (int a = 0; a < 3; ++a) n[a] /= norm;
  return true;
}

// One map node's projection onto the trilinear HU's iso-surface, and what it reads.
struct NodeProjection {
  const CtVolume& ct;
  const Mask& mask;
  const DistanceMap& map;
  const View& ct_view;
  const View& map_view;
  const Trilinear& hu;
  const std::int64_t (&step)[3];  // map nodes per CT voxel along each canonical axis
  double iso_hu, max_change_mm;
  float clamp;

  // The node (i, j, k) at map distance d: its distance to the iso-surface, signed by its side;
  // nothing where the mask overrides the HU, the map has no gradient, no surface point is found
  // in a cell the mask cuts, or the distance would change by more than max_change_mm.
  std::optional<float> at(std::int64_t i, std::int64_t j, std::int64_t k, double d) const {
    std::int64_t c[3];  // the node's canonical index
    map_view.canonical(i, j, k, c);
    const double q[3] = {static_cast<double>(c[0]) * map_view.spacing[0],
                         static_cast<double>(c[1]) * map_view.spacing[1],
                         static_cast<double>(c[2]) * map_view.spacing[2]};
    bool inside;
    if (c[0] % step[0] == 0 && c[1] % step[1] == 0 && c[2] % step[2] == 0) {
      const std::size_t n_ct = ct_view.linear(c[0] / step[0], c[1] / step[1], c[2] / step[2]);
      inside = mask.data[n_ct] != 0;
      if ((ct.data[n_ct] - iso_hu >= 0.0) != inside) return std::nullopt;  // the mask overrides
    } else {
      // Between the CT's nodes: the upsampled map's sign, unless the cell is cut by
      // the mask, where the trilinear HU's own sign says which side the node is on.
      const Sample at_q = hu.at(q);
      inside = d > 0.0;
      if ((at_q.f >= 0.0) != inside) {
        if (!cell_cut_by_mask(mask, ct_view, at_q.cell)) return std::nullopt;
        inside = at_q.f >= 0.0;
      }
    }
    double nd[3];
    if (!map_gradient(map, map_view, c, nd)) return std::nullopt;
    double x[3] = {q[0] - d * nd[0], q[1] - d * nd[1], q[2] - d * nd[2]};
    const double dist = closest_point(hu, q, x);
    if (!(dist >= 0.0)) return std::nullopt;
    if (!cell_cut_by_mask(mask, ct_view, hu.at(x).cell)) return std::nullopt;
    if (std::abs(dist - std::abs(d)) > max_change_mm) return std::nullopt;
    const float rounded = std::min(clamp, round_to_map_step(static_cast<float>(dist)));
    return inside ? rounded : -rounded;
  }
};

}  // namespace

double distance_to_iso_surface(const CtVolume& ct, double iso_hu, const double q[3],
                               double start[3]) {
  for (int a = 0; a < 3; ++a)
    if (ct.grid.dims[a] < 2) throw UsageError("iso-surface distance: the CT is too small");
  const Order storage;  // q and start are in the grid's own axes
  const View view(ct.grid, storage);
  return closest_point(Trilinear(ct, view, iso_hu), q, start);
}

IsoProjectionStats project_onto_iso_surface(const CtVolume& ct, const Mask& mask, double iso_hu,
                                            double reach_mm, double outside_mm,
                                            double max_change_mm, double clamp_mm, DistanceMap& map,
                                            unsigned threads) {
  const Grid& grid = map.grid;
  // The map lies on the CT's grid or on its aligned refinement (prep/maps/map_refine.hpp).
  const Refinement refine = refinement_between(ct.grid, grid);
  if (refine[0] == 0 || mask.grid.dims != ct.grid.dims || ct.data.size() != ct.grid.voxel_count() ||
      mask.data.size() != ct.grid.voxel_count() || map.data.size() != grid.voxel_count()) {
    throw UsageError("iso-surface projection: the CT, the mask and the map differ in grid");
  }
  IsoProjectionStats stats;
  if (!(reach_mm > 0.0)) return stats;
  for (int a = 0; a < 3; ++a)
    if (grid.dims[a] < 2) return stats;
  threads = thread_count_or_default(threads);
  const Order order = canonical_order(ct.grid);
  const View ct_view(ct.grid, order), map_view(grid, order);
  const std::int64_t step[3] = {refine[order.axis[0]], refine[order.axis[1]],
                                refine[order.axis[2]]};
  const Trilinear hu(ct, ct_view, iso_hu);
  const Index3 n = grid.dims;
  const float clamp = static_cast<float>(clamp_mm);
  const NodeProjection node{ct, mask, map,    ct_view,       map_view,
                            hu, step, iso_hu, max_change_mm, clamp};
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
              if (const std::optional<float> value = node.at(i, j, k, d))
                out.emplace_back(v, *value);
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
