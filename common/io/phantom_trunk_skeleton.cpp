// The trunk phantom's bones as painted layers (the spine, ribs, sacrum, hip bones and femora),
// and the shapes only the trunk uses: the body's lofted contour, the iliac wing's shell and the
// sacrum's frusta.
#include <algorithm>
#include <cmath>

#include "io/phantom_trunk_anatomy.hpp"

namespace palp::phantom_detail::trunk {
namespace {

// Cortical bone well above the contrast-filled lumens' HU (prep tells a bone from a lumen by a
// cortex above about 700 HU), cancellous marrow below it.
constexpr double kCortexHu = 1000.0, kMarrowHu = 250.0, kArchHu = 850.0;

Tube tube(const Vec3d& a, const Vec3d& b, double radius) {
  return {to_array(a), to_array(b), radius};
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Shapes

RowSpans Loft::spans(const RowContext& row) const {
  RowSpans out;
  const double a = body_half_width(row.z) - inset, b = kBodyB - inset;
  const double m = std::max(row.h[0], row.h[1]);
  const double outer = chord_half_width(row.y - kBodyCy, a + m, b + m);
  if (outer < 0.0) return out;
  out.add(-outer, outer);
  const double inner = chord_half_width(row.y - kBodyCy, a - m, b - m);
  if (inner >= 0.0) out.full_lo = -inner, out.full_hi = inner;
  return out;
}

double Loft::coverage(double x, const RowContext& row, double /*row_factor*/) const {
  const double a = body_half_width(row.z) - inset, b = kBodyB - inset;
  const EdgeSample e = ellipse_edge(x, row.y - kBodyCy, a, b, row.h[0], row.h[1]);
  return coverage_from(e.distance, e.voxel_size);
}

RowSpans ShellShape::spans(const RowContext& row) const {
  RowSpans out;
  const double m = row.h_max();
  const double z_lo = std::min(shell.z_bottom_front, shell.z_bottom_back);
  if (row.z < z_lo - m || row.z > shell.z_peak + m) return out;
  const double w = shell.half_thickness + m;
  const double outer =
      chord_half_width(row.y - shell.cy, shell.half_a(row.z) + w, shell.half_b(row.z) + w);
  if (outer < 0.0) return out;
  if (shell.side < 0) {
    out.add(-outer, 0.0);
  } else {
    out.add(0.0, outer);
  }
  return out;
}

double ShellShape::coverage(double x, const RowContext& row, double /*row_factor*/) const {
  const double u = x * static_cast<double>(shell.side);
  if (u <= 0.0) return 0.0;
  const double v = row.y - shell.cy;
  const double a = shell.half_a(row.z), b = shell.half_b(row.z);
  const EdgeSample e = ellipse_edge(u, v, a, b, row.h[0], row.h[1]);
  const double wall = coverage_from(shell.half_thickness - std::abs(e.distance), e.voxel_size);
  if (wall <= 0.0) return 0.0;
  const double t = std::atan2(v / b, u / a);
  const double arc = std::hypot(a * std::sin(t), b * std::cos(t));
  const double ends =
      coverage_from(std::min(t - shell.t0, shell.t1 - t) * arc, std::max(row.h[0], row.h[1]));
  const double top = coverage_from(shell.z_top(t) - row.z, row.h[2]);
  const double bottom = coverage_from(row.z - shell.z_bottom(t), row.h[2]);
  return std::min({wall, ends, top, bottom});
}

RowSpans FrustumShape::spans(const RowContext& row) const {
  RowSpans out;
  const double m = row.h_max(), d = std::max(f.da, f.db) + m;
  if (row.y < std::min(f.a.y, f.b.y) - d || row.y > std::max(f.a.y, f.b.y) + d) return out;
  if (row.z < std::min(f.a.z, f.b.z) - d || row.z > std::max(f.a.z, f.b.z) + d) return out;
  const double w = std::max(f.wa, f.wb) + m;
  out.add(f.cx - w, f.cx + w);
  return out;
}

double FrustumShape::coverage(double x, const RowContext& row, double /*row_factor*/) const {
  const Vec3d axis = f.b - f.a;
  const double length = norm(axis);
  const Vec3d dir = axis * (1.0 / length);
  const Vec3d rel{0.0, row.y - f.a.y, row.z - f.a.z};
  const double s = dot(rel, dir);
  const double t = std::clamp(s / length, 0.0, 1.0);
  const double across = dir.z * rel.y - dir.y * rel.z;  // in the sagittal plane
  const double h_along = std::hypot(dir.y * row.h[1], dir.z * row.h[2]);
  const double h_across = std::hypot(dir.z * row.h[1], dir.y * row.h[2]);
  const EdgeSample e = ellipse_edge(x - f.cx, across, f.wa + (f.wb - f.wa) * t,
                                    f.da + (f.db - f.da) * t, row.h[0], h_across);
  const double ends = coverage_from(std::min(s, length - s), h_along);
  return std::min(coverage_from(e.distance, e.voxel_size), ends);
}

TrunkLayer make_layer(const TrunkShape& shape, double hu, Tissue tissue, std::uint8_t label) {
  TrunkLayer layer{shape, hu, tissue, label};
  if (const auto* c = std::get_if<EllipticCylinder>(&shape)) {
    layer.z_min = c->z0, layer.z_max = c->z1;
  } else if (const auto* e = std::get_if<Ellipsoid>(&shape)) {
    layer.z_min = e->c[2] - e->semi[2], layer.z_max = e->c[2] + e->semi[2];
  } else if (const auto* b = std::get_if<Box>(&shape)) {
    layer.z_min = b->z0, layer.z_max = b->z1;
  } else if (const auto* t = std::get_if<Tube>(&shape)) {
    layer.z_min = std::min(t->a[2], t->b[2]) - t->radius;
    layer.z_max = std::max(t->a[2], t->b[2]) + t->radius;
  } else if (const auto* s = std::get_if<ShellShape>(&shape)) {
    layer.z_min = std::min(s->shell.z_bottom_front, s->shell.z_bottom_back);
    layer.z_max = s->shell.z_peak;
  } else if (const auto* f = std::get_if<FrustumShape>(&shape)) {
    const double d = std::max(f->f.da, f->f.db);
    layer.z_min = std::min(f->f.a.z, f->f.b.z) - d;
    layer.z_max = std::max(f->f.a.z, f->f.b.z) + d;
  }
  return layer;
}

// ---------------------------------------------------------------------------------------------
// Bones

namespace {

void add_bone(std::vector<TrunkLayer>& layers, const TrunkShape& shape, double hu,
              std::uint8_t label) {
  layers.push_back(make_layer(shape, hu, Tissue::kBone, label));
}

void add_polyline(std::vector<TrunkLayer>& layers, const std::vector<Vec3d>& points, double radius,
                  double hu, std::uint8_t label) {
  for (std::size_t n = 1; n < points.size(); ++n)
    add_bone(layers, tube(points[n - 1], points[n], radius), hu, label);
}

// A vertebra: the body (cortex and endplates, marrow), the disc above it, the arch around the
// canal, the spinous process (a plate of three parallel rods) and the transverse processes.
void add_vertebra(std::vector<TrunkLayer>& layers, const VertebraGeometry& v,
                  const VertebraGeometry* above) {
  if (above) {
    layers.push_back(
        make_layer(EllipticCylinder{0.0, (v.y + above->y) / 2.0, (v.ax + above->ax) / 2.0,
                                    (v.ay + above->ay) / 2.0, v.z_hi, above->z_lo},
                   80.0, Tissue::kPatient));
  }
  add_bone(layers, EllipticCylinder{0.0, v.y, v.ax, v.ay, v.z_lo, v.z_hi}, kCortexHu, v.label);
  add_bone(layers, EllipticCylinder{0.0, v.y, v.ax - 2.5, v.ay - 2.5, v.z_lo + 2.0, v.z_hi - 2.0},
           kMarrowHu, v.label);
  add_bone(layers,
           EllipticCylinder{0.0, v.canal_y, v.canal_ax + 6.0, v.canal_ay + 5.0, v.z_lo + 1.0,
                            v.z_hi - 1.0},
           kArchHu, v.label);
  const Vec3d across{0.0, -v.spinous_dir.z, v.spinous_dir.y};  // up the plate
  for (double offset : {-5.0, 0.0, 5.0}) {
    const Vec3d a = v.spinous_start + across * offset;
    add_bone(layers, tube(a, a + v.spinous_dir * v.spinous_length, kSpinousRadius), kArchHu,
             v.label);
  }
  for (double s : {-1.0, 1.0}) {
    add_bone(layers,
             tube({s * (v.canal_ax + 2.0), v.canal_y - 3.0, v.zc()},
                  {s * v.transverse, v.canal_y + v.transverse_back, v.zc()}, 4.5),
             kArchHu, v.label);
  }
}

void add_spine(std::vector<TrunkLayer>& layers) {
  const std::vector<VertebraGeometry>& v = vertebrae();
  // the L5/S1 disc
  layers.push_back(
      make_layer(EllipticCylinder{0.0, (v[0].y + 18.0) / 2.0, 25.0, 16.5, kSacrumTopZ, v[0].z_lo},
                 80.0, Tissue::kPatient));
  for (std::size_t n = 0; n < v.size(); ++n)
    add_vertebra(layers, v[n], n + 1 < v.size() ? &v[n + 1] : nullptr);
  // the canal (cerebrospinal fluid), through each arch and the discs' levels
  for (std::size_t n = 0; n < v.size(); ++n) {
    const double lo = n == 0 ? kSacrumTopZ : v[n - 1].z_hi, hi = v[n].z_hi + 3.0;
    layers.push_back(
        make_layer(EllipticCylinder{0.0, v[n].canal_y, v[n].canal_ax, v[n].canal_ay, lo, hi}, 20.0,
                   Tissue::kPatient));
  }
}

void add_ribs(std::vector<TrunkLayer>& layers) {
  for (const RibGeometry& rib : ribs()) {
    const std::uint8_t label = rib_label(rib.side, rib.number);
    add_polyline(layers, rib.points, kRibRadius, kCortexHu, label);
    add_polyline(layers, rib.points, kRibMarrowRadius, 300.0, label);
  }
}

// A frustum's marrow: `inset` mm inside it all round.
Frustum inset_frustum(const Frustum& f, double inset) {
  const Vec3d dir = (f.b - f.a) * (1.0 / norm(f.b - f.a));
  return {f.cx,         f.a + dir * inset, f.b - dir * inset, f.wa - inset,
          f.wb - inset, f.da - inset,      f.db - inset};
}

// The iliac wing's marrow: a thinner shell inside the cortex, its edges `inset` mm in.
IliacShell inset_shell(IliacShell s, double inset) {
  s.half_thickness -= inset;
  s.z_peak -= inset;
  s.z_bottom_front += inset;
  s.z_bottom_back += inset;
  s.t0 += inset / s.a;
  s.t1 -= inset / s.a;
  return s;
}

void add_sacrum(std::vector<TrunkLayer>& layers) {
  const PelvisGeometry& p = pelvis();
  add_bone(layers, FrustumShape{p.sacrum_alae}, kCortexHu, kLabelSacrum);
  add_bone(layers, FrustumShape{p.sacrum_body}, kCortexHu, kLabelSacrum);
  add_bone(layers, FrustumShape{inset_frustum(p.sacrum_alae, 2.5)}, kMarrowHu, kLabelSacrum);
  add_bone(layers, FrustumShape{inset_frustum(p.sacrum_body, 2.5)}, kMarrowHu, kLabelSacrum);
  add_bone(layers, tube(p.s1_crest_start, p.s1_crest_tip, kSpinousRadius), kArchHu, kLabelSacrum);
  add_bone(layers, tube(p.sacrum_body.b, {0.0, 55.0, -178.0}, 5.0), kArchHu, kLabelCoccyx);
}

// A rod of cortex with its marrow.
void add_rod(std::vector<TrunkLayer>& layers, const Vec3d& a, const Vec3d& b, double radius,
             std::uint8_t label) {
  add_bone(layers, tube(a, b, radius), kCortexHu, label);
  add_bone(layers, tube(a, b, radius - 3.0), kMarrowHu, label);
}

// An ellipsoid of cortex with its marrow.
void add_knob(std::vector<TrunkLayer>& layers, const Vec3d& c, const Vec3& semi,
              std::uint8_t label) {
  add_bone(layers, Ellipsoid{to_array(c), semi}, kCortexHu, label);
  add_bone(layers, Ellipsoid{to_array(c), {semi[0] - 3.0, semi[1] - 3.0, semi[2] - 3.0}}, kMarrowHu,
           label);
}

// One side's hip bone: the iliac wing and crest, the acetabulum, pubis and ischium.
void add_hip_bone(std::vector<TrunkLayer>& layers, int n) {
  const PelvisGeometry& p = pelvis();
  const int side = n == 0 ? -1 : 1;
  const double s = static_cast<double>(side);
  const std::uint8_t hip = hip_label(side);
  add_bone(layers, ShellShape{iliac_shell(side)}, kCortexHu, hip);
  add_bone(layers, ShellShape{inset_shell(iliac_shell(side), 2.5)}, kMarrowHu, hip);
  add_polyline(layers, p.crest[n], kCrestRadius, kCortexHu, hip);
  add_polyline(layers, p.crest[n], kCrestRadius - 2.5, kMarrowHu, hip);
  const Vec3d head = p.femoral_head[n];
  add_knob(layers, {head.x + s * 3.0, head.y + 5.0, head.z + 2.0}, {30.0, 30.0, 30.0}, hip);
  add_rod(layers, {s * 80.0, -65.0, -150.0}, {s * 18.0, -95.0, -158.0}, 8.0, hip);
  add_knob(layers, {s * 12.0, -95.0, -163.0}, {13.0, 10.0, 20.0}, hip);
  add_rod(layers, {s * 14.0, -90.0, -182.0}, {s * 55.0, -30.0, -205.0}, 7.0, hip);
  add_rod(layers, {s * 85.0, -30.0, -170.0}, {s * 58.0, -25.0, -205.0}, 9.0, hip);
  add_knob(layers, {s * 58.0, -20.0, -208.0}, {14.0, 16.0, 14.0}, hip);
}

// One side's femur: the head in the acetabulum across a joint space, the neck, the greater and
// lesser trochanters, the shaft.
void add_femur(std::vector<TrunkLayer>& layers, int n) {
  const int side = n == 0 ? -1 : 1;
  const double s = static_cast<double>(side);
  const std::uint8_t femur = femur_label(side);
  const Vec3d head = pelvis().femoral_head[n];
  layers.push_back(
      make_layer(Ellipsoid{to_array(head), {26.5, 26.5, 26.5}}, 40.0, Tissue::kPatient));
  const Vec3d trochanter{s * 140.0, -40.0, -180.0};
  const Vec3d shaft_top{s * 137.0, -40.0, -190.0}, shaft_bottom{s * 118.0, -50.0, -330.0};
  add_bone(layers, Ellipsoid{to_array(head), {24.0, 24.0, 24.0}}, kCortexHu, femur);
  add_bone(layers, tube(head, trochanter, 15.0), kCortexHu, femur);
  add_bone(layers, Ellipsoid{to_array(trochanter), {17.0, 20.0, 24.0}}, kCortexHu, femur);
  add_bone(layers, Ellipsoid{{s * 120.0, -25.0, -215.0}, {9.0, 9.0, 10.0}}, kCortexHu, femur);
  add_bone(layers, tube(shaft_top, shaft_bottom, 14.0), kCortexHu, femur);
  add_bone(layers, Ellipsoid{to_array(head), {21.0, 21.0, 21.0}}, kMarrowHu, femur);
  add_bone(layers, tube(head, trochanter, 11.0), kMarrowHu, femur);
  add_bone(layers, Ellipsoid{to_array(trochanter), {14.0, 17.0, 21.0}}, kMarrowHu, femur);
  add_bone(layers, tube(shaft_top, shaft_bottom, 9.0), 200.0, femur);
}

}  // namespace

void add_skeleton(std::vector<TrunkLayer>& layers) {
  add_ribs(layers);
  add_spine(layers);
  add_sacrum(layers);
  for (int n = 0; n < 2; ++n) add_hip_bone(layers, n);
  for (int n = 0; n < 2; ++n) add_femur(layers, n);
  // the pubic symphysis: fibrocartilage between the two pubic bodies
  layers.push_back(
      make_layer(Box{-1.5, 1.5, -106.0, -84.0, -185.0, -141.0}, 70.0, Tissue::kPatient));
}

}  // namespace palp::phantom_detail::trunk
