// Synthetic CTs: the cube and sphere (crisp, exact geometry) and the torso default scene, drawn
// row by row with partial-volume blending at every edge (see phantom.hpp for the anatomy).
#include "io/phantom.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <variant>

#include "base/errors.hpp"
#include "base/parallel.hpp"

namespace palp {
namespace {

constexpr double kAirHu = -1000.0;
constexpr double kSoftTissueHu = 40.0;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// What a voxel centre belongs to, for the truth masks.
enum class Tissue : std::uint8_t { kOutside, kPatient, kBone, kEquipment };

// ---------------------------------------------------------------------------------------------
// Grids

struct PhantomDefaults {
  Index3 dims;
  Vec3 spacing;
};

PhantomDefaults defaults_for(const std::string& name) {
  if (name == "cube") return {{140, 140, 140}, {1.0, 1.0, 1.0}};
  if (name == "sphere") return {{100, 100, 100}, {1.0, 1.0, 1.0}};
  if (name == "torso") return {{384, 256, 96}, {1.25, 1.25, 2.0}};
  std::string known;
  for (const auto& n : phantom_names()) known += (known.empty() ? "" : ", ") + n;
  throw UsageError("unknown phantom '" + name + "' (known: " + known + ")");
}

Vec3 field_of_view(const Grid& grid) {
  return {static_cast<double>(grid.dims[0]) * grid.spacing[0],
          static_cast<double>(grid.dims[1]) * grid.spacing[1],
          static_cast<double>(grid.dims[2]) * grid.spacing[2]};
}

// Uniform scale (<= 1) that fits an anatomy made for `reference` into the grid's field of view;
// `axes` says which axes must fit.
double fit_scale(const Grid& grid, const Vec3& reference, int axes) {
  const Vec3 fov = field_of_view(grid);
  double scale = 1.0;
  for (int a = 0; a < axes; ++a) scale = std::min(scale, fov[a] / reference[a]);
  return scale;
}

Vec3 grid_centre(const Grid& grid) {
  const Vec3 e = grid.extent_mm();
  return {e[0] / 2.0, e[1] / 2.0, e[2] / 2.0};
}

// ---------------------------------------------------------------------------------------------
// Partial-volume geometry. Every shape reports, per voxel, a coverage in [0, 1] from an
// approximate signed distance d (mm, positive inside) and the voxel size h along the edge normal:
// coverage = clamp(1/2 + d/h).

double coverage_from(double distance, double voxel_size) {
  return std::clamp(0.5 + distance / voxel_size, 0.0, 1.0);
}

struct EdgeSample {
  double distance;    // approximate signed distance to the edge, positive inside
  double voxel_size;  // voxel extent along the edge normal
};

// Edge of the ellipse (u/a)^2 + (v/b)^2 = 1 seen from (u, v): first-order distance
// (1 - q) / |grad q| with q the elliptic radius.
EdgeSample ellipse_edge(double u, double v, double a, double b, double hu, double hv) {
  const double gu = u / (a * a);
  const double gv = v / (b * b);
  const double g = std::sqrt(gu * gu + gv * gv);
  if (g < 1e-12) return {std::min(a, b), std::min(hu, hv)};
  const double q = std::sqrt((u / a) * (u / a) + (v / b) * (v / b));
  const double nu = gu / g;
  const double nv = gv / g;
  return {(1.0 - q) * q / g, std::sqrt(nu * nu * hu * hu + nv * nv * hv * hv)};
}

EdgeSample ellipsoid_edge(const Vec3& p, const Vec3& semi, const Vec3& h) {
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
double chord_half_width(double v, double a, double b) {
  if (a <= 0.0 || b <= 0.0 || std::abs(v) >= b) return -1.0;
  return a * std::sqrt(1.0 - (v / b) * (v / b));
}

// Coverage along one axis of the slab [lo, hi].
double slab_coverage(double x, double lo, double hi, double h) {
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

using Shape = std::variant<EllipticCylinder, Ellipsoid, Box, RibPair>;

struct Layer {
  Shape shape;
  double hu;
  Tissue tissue;
};

// ---------------------------------------------------------------------------------------------
// Torso anatomy (mm, anatomy frame: x = patient left, y = posterior, z = superior; the default
// field of view 480 x 320 x 192 mm is centred on the origin).

constexpr Vec3 kTorsoReferenceFov{480.0, 320.0, 192.0};
constexpr double kBodyCx = 20.0, kBodyCy = -20.0;  // body centre
constexpr double kBodyA = 150.0, kBodyB = 105.0;   // half width, half depth
constexpr double kPadTop = kBodyCy + kBodyB;       // the back rests on the pad
constexpr double kSpineCy = kBodyCy + 45.0;        // vertebral body centre
constexpr double kCanalCy = kSpineCy + 24.0;       // spinal canal centre
constexpr double kVertebraPeriod = 32.0;

void add_body_wall(std::vector<Layer>& layers) {
  const auto ring = [](double inset) {
    return EllipticCylinder{kBodyCx, kBodyCy, kBodyA - inset, kBodyB - inset};
  };
  layers.push_back({ring(0.0), 30.0, Tissue::kPatient});            // skin
  layers.push_back({ring(2.0), -100.0, Tissue::kPatient});          // subcutaneous fat
  layers.push_back({ring(17.0), 50.0, Tissue::kPatient});           // muscle wall
  layers.push_back({ring(29.0), kSoftTissueHu, Tissue::kPatient});  // abdominal cavity
}

void add_ribs(std::vector<Layer>& layers) {
  const double ar = kBodyA - 23.0, br = kBodyB - 23.0;  // ring inside the muscle wall
  const double t0 = -55.0 * std::numbers::pi / 180.0, t1 = 65.0 * std::numbers::pi / 180.0;
  for (double z = -22.0; z <= 88.0; z += 22.0) {
    const RibPair cortex{kBodyCx, kBodyCy, ar, br, t0, t1, z, 20.0, 3.0, 4.5, 0.0};
    RibPair marrow = cortex;
    marrow.radial = 1.6;
    marrow.height = 3.0;
    marrow.trim = 3.0;
    layers.push_back({cortex, 900.0, Tissue::kBone});
    layers.push_back({marrow, 250.0, Tissue::kBone});
  }
}

void add_organs(std::vector<Layer>& layers) {
  layers.push_back({Ellipsoid{{kBodyCx - 50.0, kBodyCy - 5.0, 10.0}, {55.0, 55.0, 50.0}}, 60.0,
                    Tissue::kPatient});  // liver
  for (double side : {-1.0, 1.0}) {      // kidneys
    layers.push_back({Ellipsoid{{kBodyCx + side * 55.0, kBodyCy + 35.0, -20.0}, {25.0, 18.0, 45.0}},
                      150.0, Tissue::kPatient});
  }
  // Lungs: domes whose bases sit above the liver and which run out through the top slice.
  layers.push_back({Ellipsoid{{kBodyCx - 70.0, kBodyCy + 5.0, 40.0 + 160.0}, {42.0, 52.0, 160.0}},
                    -850.0, Tissue::kPatient});
  layers.push_back({Ellipsoid{{kBodyCx + 70.0, kBodyCy + 5.0, 25.0 + 160.0}, {42.0, 52.0, 160.0}},
                    -850.0, Tissue::kPatient});
  // Bowel gas in the lower abdomen; the last pocket crosses the bottom slice.
  const std::array<std::array<double, 6>, 5> pockets{{{30, -45, -40, 22, 14, 18},
                                                      {-20, -50, -70, 18, 12, 15},
                                                      {60, -30, -75, 15, 10, 14},
                                                      {-60, -35, -50, 14, 10, 12},
                                                      {5, -40, -100, 20, 12, 16}}};
  for (const auto& p : pockets) {
    layers.push_back({Ellipsoid{{kBodyCx + p[0], kBodyCy + p[1], p[2]}, {p[3], p[4], p[5]}}, kAirHu,
                      Tissue::kPatient});
  }
  // Contrast-filled aorta, pressed against the front of the vertebral bodies.
  layers.push_back(
      {EllipticCylinder{kBodyCx + 10.0, kSpineCy - 25.5, 12.0, 12.0}, 250.0, Tissue::kPatient});
}

void add_spine(std::vector<Layer>& layers, double z_lo, double z_hi) {
  layers.push_back({EllipticCylinder{kBodyCx, kSpineCy, 22.0, 16.0}, 80.0, Tissue::kPatient});
  const long first = static_cast<long>(std::floor(z_lo / kVertebraPeriod)) - 1;
  const long last = static_cast<long>(std::ceil(z_hi / kVertebraPeriod)) + 1;
  for (long n = first; n <= last; ++n) {
    const double z = static_cast<double>(n) * kVertebraPeriod + 8.0;
    layers.push_back({EllipticCylinder{kBodyCx, kSpineCy, 22.0, 16.0, z - 12.5, z + 12.5}, 900.0,
                      Tissue::kBone});  // vertebral body cortex and endplates
    layers.push_back({EllipticCylinder{kBodyCx, kSpineCy, 20.0, 14.0, z - 10.5, z + 10.5}, 250.0,
                      Tissue::kBone});  // marrow
    layers.push_back({EllipticCylinder{kBodyCx, kCanalCy, 15.0, 13.0, z - 11.0, z + 9.0}, 700.0,
                      Tissue::kBone});  // arch
    layers.push_back(
        {Box{kBodyCx - 4.0, kBodyCx + 4.0, kCanalCy + 9.0, kCanalCy + 21.0, z - 9.0, z + 5.0},
         700.0, Tissue::kBone});  // spinous process
    layers.push_back(
        {Box{kBodyCx - 36.0, kBodyCx + 36.0, kCanalCy - 7.0, kCanalCy + 1.0, z - 6.0, z + 2.0},
         700.0, Tissue::kBone});  // transverse processes
  }
  layers.push_back({EllipticCylinder{kBodyCx, kCanalCy, 8.0, 8.0}, 20.0, Tissue::kPatient});
}

void add_arm(std::vector<Layer>& layers) {
  const double cx = -158.0, cy = kPadTop - 40.0;  // ~8 mm of air from the torso
  layers.push_back({EllipticCylinder{cx, cy, 38.0, 40.0}, 30.0, Tissue::kPatient});
  layers.push_back({EllipticCylinder{cx, cy, 36.0, 38.0}, -100.0, Tissue::kPatient});
  layers.push_back({EllipticCylinder{cx, cy, 30.0, 32.0}, 50.0, Tissue::kPatient});
  layers.push_back({EllipticCylinder{cx, cy - 3.0, 11.0, 11.0}, 900.0, Tissue::kBone});
  layers.push_back({EllipticCylinder{cx, cy - 3.0, 8.0, 8.0}, 120.0, Tissue::kBone});
}

void add_table(std::vector<Layer>& layers) {
  layers.push_back({Box{-kInfinity, kInfinity, kPadTop + 20.0, kPadTop + 29.0}, 300.0,
                    Tissue::kEquipment});  // carbon board across the whole field of view
  layers.push_back(
      {Box{-225.0, 225.0, kPadTop, kPadTop + 20.0}, -100.0, Tissue::kEquipment});  // gel pad
  layers.push_back({EllipticCylinder{kBodyCx + 115.0, kPadTop - 2.5, 2.5, 2.5}, 200.0,
                    Tissue::kEquipment});  // cable lying on the pad
}

// Paint order: later layers cover earlier ones.
std::vector<Layer> torso_layers(double z_lo, double z_hi) {
  std::vector<Layer> layers;
  add_table(layers);
  add_body_wall(layers);
  add_ribs(layers);
  add_organs(layers);
  add_spine(layers, z_lo, z_hi);
  add_arm(layers);
  return layers;
}

// ---------------------------------------------------------------------------------------------
// Drawing

// Deterministic noise in [-10, 10] HU from the voxel index.
int noise_hu(std::int64_t i, std::int64_t j, std::int64_t k) {
  std::uint64_t h = static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ull ^
                    static_cast<std::uint64_t>(j) * 0xC2B2AE3D27D4EB4Full ^
                    static_cast<std::uint64_t>(k) * 0x165667B19E3779F9ull;
  h ^= h >> 33;
  h *= 0xFF51AFD7ED558CCDull;
  h ^= h >> 33;
  return static_cast<int>(h % 21) - 10;
}

std::int16_t to_hu(double value) {
  return static_cast<std::int16_t>(std::clamp(std::lround(value), -32768L, 32767L));
}

// Maps voxel indices to the anatomy frame: anatomy = (scene - centre) / scale.
struct AnatomyFrame {
  Vec3 centre;
  double scale;
  Vec3 spacing;
  double coord(int axis, std::int64_t index) const {
    return (static_cast<double>(index) * spacing[axis] - centre[axis]) / scale;
  }
  Vec3 voxel_size() const { return {spacing[0] / scale, spacing[1] / scale, spacing[2] / scale}; }
};

// Puts the torso in the middle of the grid, with the pad's top face snapped halfway between two
// voxel rows so that neither the back nor the pad shares a voxel with the other.
AnatomyFrame torso_frame(const Grid& grid) {
  AnatomyFrame f{grid_centre(grid), fit_scale(grid, kTorsoReferenceFov, 2), grid.spacing};
  const double pad_top = f.centre[1] + kPadTop * f.scale;
  const double snapped = (std::round(pad_top / grid.spacing[1] - 0.5) + 0.5) * grid.spacing[1];
  f.centre[1] += snapped - pad_top;
  return f;
}

struct RowBuffers {
  std::vector<double> hu;
  std::vector<Tissue> tissue;
};

template <class S>
void paint_shape_row(const S& shape, const Layer& layer, const RowContext& row,
                     const AnatomyFrame& frame, RowBuffers& buf) {
  const RowSpans spans = shape.spans(row);
  const std::int64_t nx = static_cast<std::int64_t>(buf.hu.size());
  const double sx = frame.spacing[0] / frame.scale;
  const double x0 = frame.coord(0, 0);
  for (int s = 0; s < spans.count; ++s) {
    const double last = static_cast<double>(nx - 1);
    const auto lo = static_cast<std::int64_t>(
        std::clamp(std::ceil((spans.spans[s][0] - x0) / sx), 0.0, last + 1.0));
    const auto hi = static_cast<std::int64_t>(
        std::clamp(std::floor((spans.spans[s][1] - x0) / sx), -1.0, last));
    for (std::int64_t i = lo; i <= hi; ++i) {
      const double x = x0 + static_cast<double>(i) * sx;
      const double a = (x >= spans.full_lo && x <= spans.full_hi)
                           ? spans.row_factor
                           : shape.coverage(x, row, spans.row_factor);
      if (a <= 0.0) continue;
      buf.hu[i] += (layer.hu - buf.hu[i]) * a;
      if (a >= 0.5) buf.tissue[i] = layer.tissue;
    }
  }
}

CtVolume draw_torso(const Grid& grid, PhantomTruth* truth) {
  const AnatomyFrame frame = torso_frame(grid);
  const double z_lo = frame.coord(2, 0), z_hi = frame.coord(2, grid.dims[2] - 1);
  const std::vector<Layer> layers = torso_layers(z_lo, z_hi);
  CtVolume ct(grid, 0, "torso phantom");
  if (truth)
    *truth = {Mask(grid, 0, "torso truth"), Mask(grid, 0, "torso truth"),
              Mask(grid, 0, "torso truth")};
  const std::int64_t nx = grid.dims[0], ny = grid.dims[1];
  parallel_for_chunks(grid.dims[2], 1, [&](std::int64_t k_begin, std::int64_t k_end) {
    RowBuffers buf{std::vector<double>(nx), std::vector<Tissue>(nx)};
    for (std::int64_t k = k_begin; k < k_end; ++k) {
      for (std::int64_t j = 0; j < ny; ++j) {
        std::fill(buf.hu.begin(), buf.hu.end(), kAirHu);
        std::fill(buf.tissue.begin(), buf.tissue.end(), Tissue::kOutside);
        const RowContext row{frame.coord(1, j), frame.coord(2, k), frame.voxel_size()};
        for (const Layer& layer : layers) {
          std::visit([&](const auto& s) { paint_shape_row(s, layer, row, frame, buf); },
                     layer.shape);
        }
        const std::size_t base = grid.linear(0, j, k);
        for (std::int64_t i = 0; i < nx; ++i) {
          ct.data[base + i] = to_hu(buf.hu[i] + noise_hu(i, j, k));
          if (!truth) continue;
          const Tissue t = buf.tissue[i];
          truth->body.data[base + i] = (t == Tissue::kPatient || t == Tissue::kBone) ? 1 : 0;
          truth->bone.data[base + i] = t == Tissue::kBone ? 1 : 0;
          truth->equipment.data[base + i] = t == Tissue::kEquipment ? 1 : 0;
        }
      }
    }
  });
  return ct;
}

// Cube and sphere: crisp (a voxel is tissue when its centre is inside), no noise.
template <class Inside>
CtVolume draw_crisp(const Grid& grid, PhantomTruth* truth, Inside inside) {
  CtVolume ct(grid, 0, "phantom");
  if (truth)
    *truth = {Mask(grid, 0, "phantom truth"), Mask(grid, 0, "phantom truth"),
              Mask(grid, 0, "phantom truth")};
  parallel_for_chunks(grid.dims[2], 4, [&](std::int64_t k_begin, std::int64_t k_end) {
    for (std::int64_t k = k_begin; k < k_end; ++k) {
      for (std::int64_t j = 0; j < grid.dims[1]; ++j) {
        for (std::int64_t i = 0; i < grid.dims[0]; ++i) {
          const Vec3 p{static_cast<double>(i) * grid.spacing[0],
                       static_cast<double>(j) * grid.spacing[1],
                       static_cast<double>(k) * grid.spacing[2]};
          const bool in = inside(p);
          const std::size_t n = grid.linear(i, j, k);
          ct.data[n] = to_hu(in ? kSoftTissueHu : kAirHu);
          if (truth) truth->body.data[n] = in ? 1 : 0;
        }
      }
    }
  });
  return ct;
}

}  // namespace

std::vector<std::string> phantom_names() {
  return {"cube", "sphere", "torso"};
}

Grid phantom_grid(const std::string& name, const PhantomOptions& options) {
  const PhantomDefaults d = defaults_for(name);
  Grid grid;
  grid.dims = options.dims.value_or(d.dims);
  grid.spacing = options.spacing.value_or(d.spacing);
  try {
    validate_grid(grid, "phantom " + name);
  } catch (const InputError& e) {
    throw UsageError(e.what());
  }
  const Vec3 e = grid.extent_mm();
  grid.world.origin = {-e[0] / 2.0, -e[1] / 2.0, -e[2] / 2.0};
  if (name == "cube") {
    // "ILA": i toward inferior, j toward the left, k toward anterior (the top face). Columns of
    // the row-major direction are the i, j, k directions in LPS; origin = -D (extent / 2).
    grid.world.direction = {0, 1, 0, 0, 0, -1, -1, 0, 0};
    grid.world.origin = {-e[1] / 2.0, e[2] / 2.0, e[0] / 2.0};
  }
  return grid;
}

SphereGeometry sphere_geometry(const Grid& grid) {
  return {grid_centre(grid), 30.0 * fit_scale(grid, {100.0, 100.0, 100.0}, 3)};
}

BoxGeometry cube_geometry(const Grid& grid) {
  const double side = 100.0 * fit_scale(grid, {140.0, 140.0, 140.0}, 3);
  BoxGeometry box{};
  for (int a = 0; a < 3; ++a) {
    const std::int64_t n = grid.dims[a];
    const std::int64_t inside = std::clamp<std::int64_t>(std::llround(side / grid.spacing[a]), 1,
                                                         std::max<std::int64_t>(1, n - 2));
    const std::int64_t first = (n - inside) / 2;
    box.min[a] = (static_cast<double>(first) - 0.5) * grid.spacing[a];
    box.max[a] = (static_cast<double>(first + inside) - 0.5) * grid.spacing[a];
  }
  return box;
}

CtVolume make_phantom(const std::string& name, const PhantomOptions& options, PhantomTruth* truth) {
  const Grid grid = phantom_grid(name, options);
  if (name == "torso") return draw_torso(grid, truth);
  if (name == "sphere") {
    const SphereGeometry s = sphere_geometry(grid);
    return draw_crisp(grid, truth, [s](const Vec3& p) {
      const double dx = p[0] - s.centre[0], dy = p[1] - s.centre[1], dz = p[2] - s.centre[2];
      return dx * dx + dy * dy + dz * dz <= s.radius * s.radius;
    });
  }
  const BoxGeometry b = cube_geometry(grid);
  return draw_crisp(grid, truth, [b](const Vec3& p) {
    for (int a = 0; a < 3; ++a)
      if (p[a] < b.min[a] || p[a] > b.max[a]) return false;
    return true;
  });
}

}  // namespace palp
