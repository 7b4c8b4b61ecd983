// The trunk phantom's anatomy as geometry (phantom_trunk_anatomy.hpp): the body's contour and
// skin, the vertebrae's levels and processes, the ribs' centre lines and the pelvis's landmarks.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "io/phantom_trunk_anatomy.hpp"

namespace palp::phantom_detail::trunk {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// (z, half width): the chest, the waist above the iliac crests, the hips and thighs.
constexpr std::array<std::array<double, 2>, 8> kBodyProfile{{{-400.0, 178.0},
                                                             {-200.0, 178.0},
                                                             {-60.0, 174.0},
                                                             {0.0, 168.0},
                                                             {50.0, 152.0},
                                                             {120.0, 158.0},
                                                             {200.0, 160.0},
                                                             {400.0, 160.0}}};

double lerp(double a, double b, double t) {
  return a + (b - a) * t;
}

// One vertebra's row of the table below.
struct VertebraRow {
  const char* name;
  double height, disc_below;               // body height, the disc under it
  double y, ax, ay;                        // body centre y, half width, half depth
  double spinous_down_deg, spinous_reach;  // the process's slope, its tip's distance behind y
  double transverse;
};

// Inferior to superior. Heights and discs of an adult (thoracic bodies 20-24 mm, lumbar 26-28,
// discs 6-10 mm; T8's top 9.5 mm below the field of view's, so that no bone's marrow runs out
// through the top slice like a vessel leaving the volume), a mild lumbar lordosis (the bodies'
// centres come forward to L3), spinous processes horizontal in the lumbar spine and sloping down
// (20-50 degrees) in the thoracic.
constexpr std::array<VertebraRow, 10> kVertebrae{
    {{"L5", 28.0, 9.0, 14.0, 25.0, 17.0, 0.0, 46.0, 38.0},
     {"L4", 28.0, 10.0, 8.0, 25.0, 17.0, 0.0, 52.0, 40.0},
     {"L3", 28.0, 10.0, 5.0, 24.0, 17.0, 0.0, 54.0, 42.0},
     {"L2", 27.0, 9.0, 6.0, 23.0, 16.5, 0.0, 54.0, 38.0},
     {"L1", 26.0, 8.0, 9.0, 22.0, 16.0, 0.0, 52.0, 34.0},
     {"T12", 24.0, 7.0, 12.0, 21.0, 15.0, 20.0, 50.0, 30.0},
     {"T11", 22.0, 6.0, 15.0, 20.0, 15.0, 30.0, 48.0, 30.0},
     {"T10", 21.0, 6.0, 18.0, 19.0, 14.0, 40.0, 46.0, 30.0},
     {"T9", 20.0, 6.0, 20.0, 18.0, 14.0, 45.0, 45.0, 30.0},
     {"T8", 20.0, 6.0, 22.0, 17.0, 13.0, 50.0, 44.0, 30.0}}};

VertebraGeometry make_vertebra(const VertebraRow& row, double z_lo, std::uint8_t label) {
  VertebraGeometry v;
  v.name = row.name;
  v.label = label;
  v.thoracic = row.name[0] == 'T';
  v.z_lo = z_lo;
  v.z_hi = z_lo + row.height;
  v.y = row.y;
  v.ax = row.ax;
  v.ay = row.ay;
  v.canal_ax = v.thoracic ? 8.0 : 11.0;
  v.canal_ay = 8.0;
  v.canal_y = v.y + v.ay + v.canal_ay + 1.0;
  v.transverse = row.transverse;
  v.transverse_back = v.thoracic ? 10.0 : 0.0;
  const double a = row.spinous_down_deg * kDeg;
  v.spinous_start = {0.0, v.canal_y + v.canal_ay + 2.0, v.zc()};
  v.spinous_dir = {0.0, std::cos(a), -std::sin(a)};
  v.spinous_length = (v.y + row.spinous_reach - v.spinous_start.y) / std::cos(a) - kSpinousRadius;
  return v;
}

}  // namespace

double body_half_width(double z) {
  for (std::size_t n = 1; n < kBodyProfile.size(); ++n) {
    if (z <= kBodyProfile[n][0]) {
      const auto& p = kBodyProfile[n - 1];
      const auto& q = kBodyProfile[n];
      return lerp(p[1], q[1], std::clamp((z - p[0]) / (q[0] - p[0]), 0.0, 1.0));
    }
  }
  return kBodyProfile.back()[1];
}

Vec3d skin_normal(const Vec3d& p) {
  const double a = body_half_width(p.z), b = kBodyB;
  const double slope = (body_half_width(p.z + 0.5) - body_half_width(p.z - 0.5)) / 1.0;
  const Vec3d g{p.x / (a * a), (p.y - kBodyCy) / (b * b), -p.x * p.x * slope / (a * a * a)};
  return g * (1.0 / norm(g));
}

Vec3d skin_along_y(const Vec3d& p, double sign) {
  const double u = p.x / body_half_width(p.z);
  return {p.x, kBodyCy + sign * kBodyB * std::sqrt(std::max(0.0, 1.0 - u * u)), p.z};
}

Vec3d mid_axillary_skin(double z, int side) {
  return {static_cast<double>(side) * body_half_width(z), kBodyCy, z};
}

const std::vector<VertebraGeometry>& vertebrae() {
  static const std::vector<VertebraGeometry> table = [] {
    std::vector<VertebraGeometry> out;
    double z = kSacrumTopZ;
    for (const VertebraRow& row : kVertebrae) {
      z += row.disc_below;
      const int n = std::atoi(row.name + 1);
      const auto label = static_cast<std::uint8_t>(row.name[0] == 'T' ? n : 12 + n);
      out.push_back(make_vertebra(row, z, label));
      z = out.back().z_hi;
    }
    return out;
  }();
  return table;
}

std::string vertebral_level(double z) {
  const std::vector<VertebraGeometry>& v = vertebrae();
  if (z < v.front().z_lo) return z < kSacrumTopZ ? "S" : "L5/S1";
  for (std::size_t n = 0; n < v.size(); ++n) {
    if (z <= v[n].z_hi) return v[n].name;
    if (n + 1 < v.size() && z < v[n + 1].z_lo) return v[n + 1].name + "/" + v[n].name;
  }
  return v.back().name;
}

// Rib N: its head beside vertebra TN's body (upper part), its neck back to the transverse
// process's tip (the tubercle), then along a ring 25 mm inside the skin (its centre the body's
// centre, so the ring's lateral point is on the MAL's plane) from 68 degrees behind the lateral
// point forward to its end, descending 15 mm from the tubercle to the MAL and 10 mm per 50
// degrees beyond. Ends: ribs 8-10 in front (55, 45, 35 degrees), 11 just past the MAL (12
// degrees), 12 behind it (34 degrees behind: a floating rib that never reaches the MAL).
const std::vector<RibGeometry>& ribs() {
  static const std::vector<RibGeometry> table = [] {
    std::vector<RibGeometry> out;
    constexpr std::array<double, 5> kEndDeg{-55.0, -45.0, -35.0, -12.0, 34.0};
    constexpr double kStartDeg = 68.0, kStepDeg = 8.5;
    for (int side : {-1, 1}) {
      for (int number = 8; number <= 12; ++number) {
        const VertebraGeometry* v = nullptr;
        for (const VertebraGeometry& w : vertebrae())
          if (w.thoracic && std::atoi(w.name.c_str() + 1) == number) v = &w;
        const double s = static_cast<double>(side);
        const double z_head = v->zc() + 0.3 * (v->z_hi - v->z_lo);
        RibGeometry rib;
        rib.side = side;
        rib.number = number;
        rib.points.push_back({s * (v->ax + 6.0), v->y + 0.3 * v->ay, z_head});
        rib.points.push_back(
            {s * (v->transverse + 3.0), v->canal_y + v->transverse_back - 8.0, z_head - 1.5});
        const double ar = body_half_width(z_head) - 25.0, br = kBodyB - 22.0;
        const double end = kEndDeg[static_cast<std::size_t>(number - 8)];
        const double z_mal = z_head - 18.0;
        for (double t = kStartDeg;; t -= kStepDeg) {
          const double tt = std::max(t, end);
          const double z =
              tt >= 0.0 ? lerp(z_mal, z_head - 3.0, tt / kStartDeg) : z_mal + 10.0 * tt / 50.0;
          if (std::abs(tt) < 1e-9) rib.mid_axillary_index = static_cast<int>(rib.points.size());
          rib.points.push_back(
              {s * ar * std::cos(tt * kDeg), kBodyCy + br * std::sin(tt * kDeg), z});
          if (tt <= end) break;
        }
        out.push_back(std::move(rib));
      }
    }
    return out;
  }();
  return table;
}

double IliacShell::half_a(double z) const {
  return lerp(a_low, a, std::clamp((z - z_low) / (z_narrow - z_low), 0.0, 1.0));
}
double IliacShell::half_b(double z) const {
  return lerp(b_low, b, std::clamp((z - z_low) / (z_narrow - z_low), 0.0, 1.0));
}
double IliacShell::z_top(double t) const {
  const double d = t - t_peak;
  return z_peak - (d < 0.0 ? k_front : k_back) * d * d;
}
double IliacShell::z_bottom(double t) const {
  return lerp(z_bottom_front, z_bottom_back, (t - t0) / (t1 - t0));
}
Vec3d IliacShell::at(double t, double z) const {
  return {static_cast<double>(side) * half_a(z) * std::cos(t), cy + half_b(z) * std::sin(t), z};
}

// The wing from the anterior superior iliac spine (42 degrees in front of the lateral point) back
// past the sacrum's ala (80 degrees behind), its crest highest 10 degrees behind the lateral
// point (the crest's top at the L4/L5 disc's middle, z = -8 mm), its anterior end 54 mm lower and
// its posterior end 45 mm lower.
IliacShell iliac_shell(int side) {
  IliacShell s;
  s.side = side;
  s.t0 = -42.0 * kDeg;
  s.t1 = 80.0 * kDeg;
  s.t_peak = 10.0 * kDeg;
  s.z_peak = -8.0 - kCrestRadius;
  s.k_front = 54.0 / ((s.t_peak - s.t0) * (s.t_peak - s.t0));
  s.k_back = 30.0;
  return s;
}

const PelvisGeometry& pelvis() {
  static const PelvisGeometry table = [] {
    PelvisGeometry p;
    p.sacrum_body = {0.0, {0.0, 18.0, kSacrumTopZ - 2.0}, {0.0, 62.0, -150.0}, 26.0, 10.0, 16.0,
                     7.0};
    p.sacrum_alae = {0.0, {0.0, 26.0, -56.0}, {0.0, 44.0, -105.0}, 47.0, 30.0, 18.0, 9.0};
    p.s1_crest_start = {0.0, 30.0, -60.0};
    p.s1_crest_tip = {0.0, 52.0, -62.0};
    p.symphysis = {0.0, -105.0, -163.0};
    for (int n = 0; n < 2; ++n) {
      const int side = n == 0 ? -1 : 1;
      const double s = static_cast<double>(side);
      const IliacShell shell = iliac_shell(side);
      for (double deg = -42.0; deg <= 80.0 + 1e-9; deg += 4.0) {
        const double t = std::min(deg, 80.0) * kDeg;
        p.crest[n].push_back(shell.at(t, shell.z_top(t)));
      }
      p.crest_top[n] = shell.at(shell.t_peak, shell.z_peak) + Vec3d{0.0, 0.0, kCrestRadius};
      p.asis[n] = p.crest[n].front();
      p.femoral_head[n] = {s * 92.0, -50.0, -150.0};
      // The mid-inguinal point's level and side; the artery 15 mm under the anterior skin there.
      const Vec3d mid = (p.asis[n] + p.symphysis) * 0.5;
      const Vec3d inguinal = skin_along_y(mid, -1.0) + Vec3d{0.0, 15.0, 0.0};
      p.inguinal_artery[n] = inguinal;
      auto& a = p.femoral_artery[n];
      a.push_back({s * 46.0, -10.0, -50.0});  // where the common iliac divides
      a.push_back({s * 50.0, -55.0, -85.0});  // the external iliac along the pelvic brim
      a.push_back(inguinal);
      for (const auto& [lateral, z] : {std::array<double, 2>{56.0, -170.0},
                                       {64.0, -240.0},
                                       std::array<double, 2>{70.0, -320.0}})
        a.push_back(skin_along_y({s * lateral, 0.0, z}, -1.0) + Vec3d{0.0, 18.0, 0.0});
    }
    return p;
  }();
  return table;
}

}  // namespace palp::phantom_detail::trunk
