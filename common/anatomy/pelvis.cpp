// The hip bones, iliac crests, ASIS, symphysis and femoral pulse points (pelvis.hpp).
#include "anatomy/pelvis.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace palp::anatomy {
namespace {

// The hip bone lies beyond this distance from the midline (mm): past the lumbar transverse
// processes (L3's reach about 45 mm) and the sacrum's body; the iliac crests lie 100-150 mm out.
constexpr double kLateralMm = 45.0;
// A hip bone holds at least this much bone (ml; an adult's is 300-700 ml with its marrow).
constexpr double kMinHipMl = 50.0;

double voxel_ml(const PatientMask& m) {
  return m.spacing[0] * m.spacing[1] * m.spacing[2] * 1e-3;
}

// The largest piece on side s (0 right, 1 left) beyond kLateralMm, large enough to be a hip bone
// and reaching the sacrum's level when there is a sacrum.
const Piece* hip_bone(const std::vector<Piece>& pieces, const PatientMask& bone, double mid, int s,
                      const VertebraSegment* sacrum) {
  const Piece* best = nullptr;
  for (const Piece& p : pieces) {
    if ((p.centroid.x < mid) != (s == 0)) continue;
    if (static_cast<double>(p.voxels.size()) * voxel_ml(bone) < kMinHipMl) continue;
    if (sacrum && (static_cast<double>(p.lo[2]) > sacrum->z_hi ||
                   static_cast<double>(p.hi[2]) < sacrum->z_lo))
      continue;
    if (!best || p.voxels.size() > best->voxels.size()) best = &p;
  }
  return best;
}

// The top of a piece: the centroid of its highest slice's voxels, lifted to the bone's surface
// (half a slice above that slice's centres).
Vec3d top_of(const PatientMask& bone, const Piece& p) {
  Vec3d sum{};
  double n = 0.0;
  for (std::size_t v : p.voxels) {
    const Index3 q = index3(bone, v);
    if (q[2] != p.hi[2]) continue;
    sum += Vec3d{static_cast<double>(q[0]), static_cast<double>(q[1]), static_cast<double>(q[2])};
    n += 1.0;
  }
  Vec3d top = sum * (1.0 / n);
  top.z += 0.5;
  return top;
}

// The ASIS: the hip bone's most anterior bone above `above` (index z).
Vec3d asis_of(const PatientMask& bone, const Piece& p, double above) {
  Vec3d sum{};
  double n = 0.0, front = 1e30;
  for (std::size_t v : p.voxels) {
    const Index3 q = index3(bone, v);
    if (static_cast<double>(q[2]) < above) continue;
    const auto y = static_cast<double>(q[1]);
    if (y < front) front = y, sum = {}, n = 0.0;
    if (y == front) sum += Vec3d{static_cast<double>(q[0]), y, static_cast<double>(q[2])}, n += 1.0;
  }
  return sum * (1.0 / n);
}

// The symphysis's upper border: bone within 15 mm of the midline in the body's anterior half,
// below the crests' tops; the centroid of its top 10 mm.
std::optional<Vec3d> symphysis_of(const ScanContext& scan, double below_z) {
  const PatientMask& b = scan.bone;
  const auto half = std::lround(15.0 / b.spacing[0]);
  const auto mid = std::lround(scan.midline_x);
  std::int64_t top = -1;
  for (std::int64_t z = std::min<std::int64_t>(b.dims[2] - 1, static_cast<std::int64_t>(below_z));
       z >= 0 && top < 0; --z) {
    const SliceBody& body = scan.bodies[static_cast<std::size_t>(z)];
    if (!body.voxels) continue;
    for (std::int64_t y = 0; y < std::lround(body.cy) && top < 0; ++y)
      for (std::int64_t x = mid - half; x <= mid + half; ++x)
        if (b.at(x, y, z)) {
          top = z;
          break;
        }
  }
  if (top < 0) return std::nullopt;
  Vec3d sum{};
  double n = 0.0;
  const auto depth = std::max<std::int64_t>(1, std::lround(10.0 / b.spacing[2]));
  for (std::int64_t z = std::max<std::int64_t>(0, top - depth + 1); z <= top; ++z) {
    const SliceBody& body = scan.bodies[static_cast<std::size_t>(z)];
    for (std::int64_t y = 0; y < std::lround(body.cy); ++y)
      for (std::int64_t x = mid - half; x <= mid + half; ++x)
        if (b.at(x, y, z))
          sum += Vec3d{static_cast<double>(x), static_cast<double>(y), static_cast<double>(z)},
              n += 1.0;
  }
  Vec3d s = sum * (1.0 / n);
  s.z = static_cast<double>(top) + 0.5;
  return s;
}

}  // namespace

Pelvis find_pelvis(const ScanContext& scan, const Spine& spine) {
  Pelvis pelvis;
  const PatientMask& b = scan.bone;
  const double mid = scan.midline_x, lateral = kLateralMm / b.spacing[0];
  const auto pieces = pieces_of(
      b,
      [&](std::int64_t x, std::int64_t, std::int64_t) {
        return std::fabs(static_cast<double>(x) - mid) >= lateral;
      },
      static_cast<std::size_t>(kMinHipMl / voxel_ml(b)));
  const VertebraSegment* sacrum =
      spine.sacrum >= 0 ? &spine.segments[static_cast<std::size_t>(spine.sacrum)] : nullptr;
  double lowest_top = 1e30;
  for (int s = 0; s < 2; ++s) {
    const Piece* hip = hip_bone(pieces, b, mid, s, sacrum);
    if (!hip) {
      pelvis.reason[static_cast<std::size_t>(s)] =
          sacrum ? "no hip bone beside the sacrum on this side in the scan"
                 : "no hip bone in the scan (no bone piece of a hip bone's size lateral of the "
                   "column)";
      continue;
    }
    if (hip->hi[2] >= b.dims[2] - 1) {
      pelvis.reason[static_cast<std::size_t>(s)] =
          "the hip bone reaches the scan's upper edge: its crest is cut";
      continue;
    }
    const Vec3d top = top_of(b, *hip);
    pelvis.crest_top[static_cast<std::size_t>(s)] = top;
    // Beside a sacrum: sure; without one, a large lateral piece may be something else.
    pelvis.confidence[static_cast<std::size_t>(s)] = sacrum ? 0.9 : 0.5;
    if (!sacrum)
      pelvis.reason[static_cast<std::size_t>(s)] = "no sacrum found to confirm the hip bone";
    lowest_top = std::min(lowest_top, top.z);
  }
  if (lowest_top > 1e29) return pelvis;
  pelvis.symphysis = symphysis_of(scan, lowest_top - 50.0 / b.spacing[2]);
  if (!pelvis.symphysis) return pelvis;
  // The ASIS lies about 60 % of the way from the symphysis up to the crest's top; below 45 %
  // the superior pubic ramus and the acetabulum reach as far forward.
  for (int s = 0; s < 2; ++s) {
    const Piece* hip = hip_bone(pieces, b, mid, s, sacrum);
    const auto& top = pelvis.crest_top[static_cast<std::size_t>(s)];
    if (!hip || !top) continue;
    const double above = pelvis.symphysis->z + 0.45 * (top->z - pelvis.symphysis->z);
    pelvis.asis[static_cast<std::size_t>(s)] = asis_of(b, *hip, above);
  }
  return pelvis;
}

namespace {

// Below the inguinal ligament (which runs from the ASIS to the pubic tubercle) the common
// femoral artery lies in the femoral triangle: look this far below the mid-inguinal point (mm)
// and this far to either side of it.
constexpr double kBelowLigamentMm = 10.0;
constexpr double kArteryReachMm = 35.0;

// The artery's centre in the slice `below` the mid-inguinal point m, within reach of it.
std::optional<Vec3d> artery_below(const ScanContext& scan, const Vec3d& m) {
  if (!scan.artery) return std::nullopt;
  const PatientMask& a = *scan.artery;
  const auto z = std::lround(m.z - kBelowLigamentMm / a.spacing[2]);
  if (z < 0 || z >= a.dims[2]) return std::nullopt;
  Vec3d sum{};
  double n = 0.0;
  for (std::int64_t y = 0; y < a.dims[1]; ++y)
    for (std::int64_t x = 0; x < a.dims[0]; ++x) {
      if (!a.at(x, y, z)) continue;
      const double dx = (static_cast<double>(x) - m.x) * a.spacing[0];
      const double dy = (static_cast<double>(y) - m.y) * a.spacing[1];
      if (std::hypot(dx, dy) > kArteryReachMm) continue;
      sum += Vec3d{static_cast<double>(x), static_cast<double>(y), static_cast<double>(z)},
          n += 1.0;
    }
  if (n <= 0.0) return std::nullopt;
  return sum * (1.0 / n);
}

}  // namespace

std::vector<FemoralPulsePoint> femoral_pulse_points(const ScanContext& scan, const Pelvis& pelvis) {
  std::vector<FemoralPulsePoint> out;
  for (int s = 0; s < 2; ++s) {
    FemoralPulsePoint f;
    f.side = side_of(s);
    const auto& asis = pelvis.asis[static_cast<std::size_t>(s)];
    if (!asis || !pelvis.symphysis) {
      f.reason = !pelvis.crest_top[static_cast<std::size_t>(s)]
                     ? "the pelvis is not in the scan on this side (" +
                           pelvis.reason[static_cast<std::size_t>(s)] + ")"
                     : "the pubic symphysis is not in the scan";
      out.push_back(f);
      continue;
    }
    const Vec3d mid_inguinal = (*asis + *pelvis.symphysis) * 0.5;
    const auto artery = artery_below(scan, mid_inguinal);
    const Vec3d over = artery ? *artery : mid_inguinal;
    const auto skin = skin_along(scan, scan.bone.world(over), {0.0, -1.0, 0.0});
    if (!skin) {
      f.reason = "no skin anterior of the femoral point in the scan";
      out.push_back(f);
      continue;
    }
    f.skin_point = skin->point, f.normal = skin->normal;
    f.source = artery ? "artery" : "mid-inguinal";
    // The artery seen: as sure as the hip bone; from the bones: the mid-inguinal point lies
    // within about 15 mm of the artery in most adults, so less.
    f.confidence = pelvis.confidence[static_cast<std::size_t>(s)] * (artery ? 1.0 : 0.7);
    if (!artery)
      f.reason = scan.artery ? "no artery within reach below the mid-inguinal point in " +
                                   scan.artery_source
                             : "the scan shows no artery: the mid-inguinal point from the bones";
    out.push_back(f);
  }
  return out;
}

}  // namespace palp::anatomy
