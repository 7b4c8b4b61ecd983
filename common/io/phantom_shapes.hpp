// Internal to the phantom sources (phantom.cpp, phantom_torso.cpp): the shapes the torso is drawn
// from, with partial-volume coverage at every edge, the tissue classes of the truth masks, and the
// helpers the cube and sphere share with it. Not part of palp::io's interface.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <variant>

#include "io/phantom.hpp"

namespace palp::phantom_detail {

constexpr double kAirHu = -1000.0;
constexpr double kSoftTissueHu = 40.0;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// What a voxel centre belongs to, for the truth masks. Vessel lumens are "contrast" when drawn at
// least kContrastAboveTissueHu above soft tissue (visibly contrast-filled), "plain" otherwise.
enum class Tissue : std::uint8_t {
  kOutside,
  kPatient,
  kBone,
  kEquipment,
  kArteryContrast,
  kArteryPlain,
  kVeinContrast,
  kVeinPlain,
  kMetal,  // an implant: part of the bone truth (rigid, inside a vertebra) and of the metal truth
  kLiver,  // the liver's parenchyma (its vessels are vessels)
};
constexpr double kContrastAboveTissueHu = 60.0;

inline Vec3 field_of_view(const Grid& grid) {
  return {static_cast<double>(grid.dims[0]) * grid.spacing[0],
          static_cast<double>(grid.dims[1]) * grid.spacing[1],
          static_cast<double>(grid.dims[2]) * grid.spacing[2]};
}

// Uniform scale (<= 1) that fits an anatomy made for `reference` into the grid's field of view;
// `axes` says which axes must fit.
inline double fit_scale(const Grid& grid, const Vec3& reference, int axes) {
  const Vec3 fov = field_of_view(grid);
  double scale = 1.0;
  for (int a = 0; a < axes; ++a) scale = std::min(scale, fov[a] / reference[a]);
  return scale;
}

inline Vec3 grid_centre(const Grid& grid) {
  const Vec3 e = grid.extent_mm();
  return {e[0] / 2.0, e[1] / 2.0, e[2] / 2.0};
}
// ---------------------------------------------------------------------------------------------
// Partial-volume geometry. Every shape reports, per voxel, a coverage in [0, 1] from an
// approximate signed distance d (mm, positive inside) and the voxel size h along the edge normal:
// coverage = clamp(1/2 + d/h).

inline double coverage_from(double distance, double voxel_size) {
  return std::clamp(0.5 + distance / voxel_size, 0.0, 1.0);
}

struct EdgeSample {
  double distance;    // approximate signed distance to the edge, positive inside
  double voxel_size;  // voxel extent along the edge normal
};

// Edge of the ellipse (u/a)^2 + (v/b)^2 = 1 seen from (u, v): first-order distance
// (1 - q) / |grad q| with q the elliptic radius.
inline EdgeSample ellipse_edge(double u, double v, double a, double b, double hu, double hv) {
  const double gu = u / (a * a);
  const double gv = v / (b * b);
  const double g = std::sqrt(gu * gu + gv * gv);
  if (g < 1e-12) return {std::min(a, b), std::min(hu, hv)};
  const double q = std::sqrt((u / a) * (u / a) + (v / b) * (v / b));
  const double nu = gu / g;
  const double nv = gv / g;
  return {(1.0 - q) * q / g, std::sqrt(nu * nu * hu * hu + nv * nv * hv * hv)};
}

inline EdgeSample ellipsoid_edge(const Vec3& p, const Vec3& semi, const Vec3& h) {
  Vec3 grad{};
  double g2 = 0.0;
  double q2 = 0.0;
  for (int a = 0; a < 3; ++a) {
    grad[a] = p[a] / (semi[a] * semi[a]);
    g2 += grad[a] * grad[a];
    q2 += (p[a] / semi[a]) * (p[a] / semi[a]);
  }
  const double g = std::sqrt(g2);
  if (g < 1e-12) return {std::min({semi[0], semi[1], semi[2]}), std::min({h[0], h[1], h[2]})};
  const double q = std::sqrt(q2);
  double size2 = 0.0;
  for (int a = 0; a < 3; ++a) size2 += (grad[a] / g) * (grad[a] / g) * h[a] * h[a];
  return {(1.0 - q) * q / g, std::sqrt(size2)};
}

// Half-width of the ellipse with semi-axes (a, b) on the line v; negative when it misses.
inline double chord_half_width(double v, double a, double b) {
  if (a <= 0.0 || b <= 0.0 || std::abs(v) >= b) return -1.0;
  return a * std::sqrt(1.0 - (v / b) * (v / b));
}

// Coverage along one axis of the slab [lo, hi].
inline double slab_coverage(double x, double lo, double hi, double h) {
  return coverage_from(std::min(x - lo, hi - x), h);
}

// x-ranges of one row (mm) where a shape may cover voxels. Inside `full` (when set) the in-plane
// coverage is 1 and only the row's own factor (`row_factor`, e.g. from z limits) applies.
struct RowSpans {
  std::array<std::array<double, 2>, 2> spans{};
  int count = 0;
  double full_lo = kInfinity;
  double full_hi = -kInfinity;
  double row_factor = 1.0;
  void add(double lo, double hi) {
    if (lo <= hi) spans[count++] = {lo, hi};
  }
};

// Voxel sizes of the anatomy frame (mm in anatomy units).
struct RowContext {
  double y;
  double z;
  Vec3 h;
  double h_max() const { return std::max({h[0], h[1], h[2]}); }
};

// A cylinder with elliptic cross-section along z, cut at z0 and z1 (which may be infinite).
struct EllipticCylinder {
  double cx, cy, ax, ay;
  double z0 = -kInfinity, z1 = kInfinity;

  RowSpans spans(const RowContext& row) const {
    RowSpans out;
    out.row_factor = slab_coverage(row.z, z0, z1, row.h[2]);
    if (out.row_factor <= 0.0) return out;
    const double m = std::max(row.h[0], row.h[1]);
    const double outer = chord_half_width(row.y - cy, ax + m, ay + m);
    if (outer < 0.0) return out;
    out.add(cx - outer, cx + outer);
    const double inner = chord_half_width(row.y - cy, ax - m, ay - m);
    if (inner >= 0.0) out.full_lo = cx - inner, out.full_hi = cx + inner;
    return out;
  }
  double coverage(double x, const RowContext& row, double row_factor) const {
    const EdgeSample e = ellipse_edge(x - cx, row.y - cy, ax, ay, row.h[0], row.h[1]);
    return std::min(coverage_from(e.distance, e.voxel_size), row_factor);
  }
};

struct Ellipsoid {
  Vec3 c;
  Vec3 semi;

  RowSpans spans(const RowContext& row) const {
    RowSpans out;
    const double m = row.h_max();
    const double dz = row.z - c[2];
    const auto cross_half_width = [&](double grow) {
      const double sz = semi[2] + grow;
      if (std::abs(dz) >= sz) return -1.0;
      const double f = std::sqrt(1.0 - (dz / sz) * (dz / sz));
      return chord_half_width(row.y - c[1], (semi[0] + grow) * f, (semi[1] + grow) * f);
    };
    const double outer = cross_half_width(m);
    if (outer < 0.0) return out;
    out.add(c[0] - outer, c[0] + outer);
    const double inner = cross_half_width(-m);
    if (inner >= 0.0) out.full_lo = c[0] - inner, out.full_hi = c[0] + inner;
    return out;
  }
  double coverage(double x, const RowContext& row, double /*row_factor*/) const {
    const EdgeSample e = ellipsoid_edge({x - c[0], row.y - c[1], row.z - c[2]}, semi, row.h);
    return coverage_from(e.distance, e.voxel_size);
  }
};

// Axis-aligned box; any bound may be infinite.
struct Box {
  double x0, x1, y0, y1;
  double z0 = -kInfinity, z1 = kInfinity;

  RowSpans spans(const RowContext& row) const {
    RowSpans out;
    out.row_factor =
        std::min(slab_coverage(row.y, y0, y1, row.h[1]), slab_coverage(row.z, z0, z1, row.h[2]));
    if (out.row_factor <= 0.0) return out;
    out.add(x0 - row.h[0], x1 + row.h[0]);
    out.full_lo = x0 + row.h[0] / 2.0;
    out.full_hi = x1 - row.h[0] / 2.0;
    return out;
  }
  double coverage(double x, const RowContext& row, double row_factor) const {
    return std::min(slab_coverage(x, x0, x1, row.h[0]), row_factor);
  }
};

// A pair of mirrored ribs (left and right): a band of elliptic cross-section (radial semi-axis
// `radial`, height semi-axis `height`) that follows the ring ellipse (cx, cy, ar, br) from the
// parametric angle t0 (anterior, negative) to t1 (posterior; +pi/2 is straight back), rising by
// `rise` mm from front to back. `trim` shortens both ends (mm of arc), for the marrow.
struct RibPair {
  double cx, cy, ar, br;
  double t0, t1;
  double z_front, rise;
  double radial, height;
  double trim = 0.0;

  RowSpans spans(const RowContext& row) const {
    RowSpans out;
    const double m = row.h_max();
    if (row.z < z_front - height - m || row.z > z_front + rise + height + m) return out;
    const double v = row.y - cy;
    const double outer = chord_half_width(v, ar + radial + m, br + radial + m);
    if (outer < 0.0) return out;
    const double inner = chord_half_width(v, ar - radial - m, br - radial - m);
    if (inner < 0.0) {
      out.add(cx - outer, cx + outer);
    } else {
      out.add(cx - outer, cx - inner);
      out.add(cx + inner, cx + outer);
    }
    return out;
  }
  double coverage(double x, const RowContext& row, double /*row_factor*/) const {
    const double u = std::abs(x - cx);
    const double v = row.y - cy;
    const double t = std::atan2(v / br, u / ar);
    const double hxy = std::max(row.h[0], row.h[1]);
    const double arc_per_radian = std::hypot(ar * std::sin(t), br * std::cos(t));
    const double end_distance = std::min(t - t0, t1 - t) * arc_per_radian - trim;
    const double end_coverage = coverage_from(end_distance, hxy);
    if (end_coverage <= 0.0) return 0.0;
    const EdgeSample ring = ellipse_edge(u, v, ar, br, row.h[0], row.h[1]);
    const double outward = -ring.distance;
    const double dz = row.z - (z_front + rise * (t - t0) / (t1 - t0));
    const EdgeSample cross = ellipse_edge(outward, dz, radial, height, ring.voxel_size, row.h[2]);
    return std::min(coverage_from(cross.distance, cross.voxel_size), end_coverage);
  }
};

// A capsule: the points within `radius` of the segment a -> b (rounded ends), for vessels that
// leave the aorta sideways or obliquely and for implants.
struct Tube {
  Vec3 a, b;
  double radius;

  RowSpans spans(const RowContext& row) const {
    // Points of the segment whose (y, z) lie within radius + a voxel of the row's: a t-interval
    // (|p + t q|^2 <= r^2, p and q the offset and direction in y, z); any voxel of the row within
    // that distance of the segment has its x within the same of those points' x.
    RowSpans out;
    const double reach = radius + row.h_max();
    const double py = a[1] - row.y, pz = a[2] - row.z;
    const double qy = b[1] - a[1], qz = b[2] - a[2];
    const double qq = qy * qy + qz * qz, pq = py * qy + pz * qz;
    const double c = py * py + pz * pz - reach * reach;
    double t0 = 0.0, t1 = 1.0;
    if (qq < 1e-12) {
      if (c > 0.0) return out;
    } else {
      const double disc = pq * pq - qq * c;
      if (disc < 0.0) return out;
      const double root = std::sqrt(disc);
      t0 = std::max(0.0, (-pq - root) / qq);
      t1 = std::min(1.0, (-pq + root) / qq);
      if (t0 > t1) return out;
    }
    const double x0 = a[0] + t0 * (b[0] - a[0]), x1 = a[0] + t1 * (b[0] - a[0]);
    out.add(std::min(x0, x1) - reach, std::max(x0, x1) + reach);
    return out;
  }
  double coverage(double x, const RowContext& row, double /*row_factor*/) const {
    const Vec3 d{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const Vec3 p{x - a[0], row.y - a[1], row.z - a[2]};
    const double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    const double t =
        dd > 0.0 ? std::clamp((p[0] * d[0] + p[1] * d[1] + p[2] * d[2]) / dd, 0.0, 1.0) : 0.0;
    const Vec3 n{p[0] - t * d[0], p[1] - t * d[1], p[2] - t * d[2]};
    const double dist = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (dist < 1e-9) return coverage_from(radius, row.h_max());
    double size2 = 0.0;
    for (int k = 0; k < 3; ++k) size2 += (n[k] / dist) * (n[k] / dist) * row.h[k] * row.h[k];
    return coverage_from(radius - dist, std::sqrt(size2));
  }
};

using Shape = std::variant<EllipticCylinder, Ellipsoid, Box, RibPair, Tube>;

struct Layer {
  Shape shape;
  double hu;
  Tissue tissue;
};

// Deterministic noise in [-10, 10] HU from the voxel index.
inline int noise_hu(std::int64_t i, std::int64_t j, std::int64_t k) {
  std::uint64_t h = static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ull ^
                    static_cast<std::uint64_t>(j) * 0xC2B2AE3D27D4EB4Full ^
                    static_cast<std::uint64_t>(k) * 0x165667B19E3779F9ull;
  h ^= h >> 33;
  h *= 0xFF51AFD7ED558CCDull;
  h ^= h >> 33;
  return static_cast<int>(h % 21) - 10;
}

inline std::int16_t to_hu(double value) {
  return static_cast<std::int16_t>(std::clamp(std::lround(value), -32768L, 32767L));
}

inline PhantomTruth empty_truth(const Grid& grid, const char* name) {
  PhantomTruth t;
  for (Mask* m : {&t.body, &t.bone, &t.equipment, &t.vessel, &t.artery, &t.metal, &t.liver})
    *m = Mask(grid, 0, name);
  return t;
}

CtVolume draw_torso(const Grid& grid, const PhantomOptions& options, PhantomTruth* truth);
// The trunk on its LPS grid (phantom_trunk.cpp); make_phantom applies `orient` afterwards.
CtVolume draw_trunk(const Grid& grid, const PhantomOptions& options, PhantomTruth* truth);

}  // namespace palp::phantom_detail
