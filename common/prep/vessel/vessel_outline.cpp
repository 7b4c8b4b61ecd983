// A lumen's round outline across the body axis (see vessel_outline.hpp). Data flow per slice:
//   pieces   lumen in the slice -> 4-connected pieces, their centres and areas
//   rays     piece, CT, cortex -> the points where rays from its centre meet fat or air
//   circle   points -> least-squares circle, outliers dropped -> kept when round and fat-bound
//   fill     circle, CT, cortex -> the tissue inside it, added to the lumen after every slice
#include "prep/vessel/vessel_outline.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include "base/parallel.hpp"
#include "prep/segment/segmentation.hpp"
#include "prep/segment/slice_planes.hpp"
#include "prep/vessel/vessel_segmentation.hpp"

namespace palp {
namespace {

constexpr double kPi = 3.14159265358979323846;

using segmentation::Plane;  // an axial slice: voxel (u, v) at p.at(u, v), u_mm x v_mm
using segmentation::Run;

struct Piece {
  double u_mm = 0.0, v_mm = 0.0;  // centre
  double area_mm2 = 0.0;
};

struct Point {
  double u, v;               // mm
  bool via_calcium = false;  // behind a calcified wall
};

struct Circle {
  double u, v, radius, rms;
};

// The plane with v in the grid's index order: axial_plane runs v from the patient's back, but the
// rays' sampling (rounding to voxels) was measured with v growing with the index, and mirrored it
// rounds a few ties the other way (58 of the shared contrast case's 304,679 vessel voxels).
Plane index_ordered(Plane p) {
  if (p.sv < 0) {
    p.base += (p.nv - 1) * p.sv;
    p.sv = -p.sv;
  }
  return p;
}

// The 4-connected pieces of `lumen` in the plane (segmentation::label_plane), each's centre
// (mm, from the plane's first voxel) and area.
std::vector<Piece> pieces_in(const Plane& p, const Mask& lumen, segmentation::PlaneScratch& s) {
  segmentation::label_plane(p, lumen.data.data(), false, s);
  const std::vector<Run>& runs = s.runs.runs;
  std::vector<std::int64_t> piece_of(runs.size(), -1);
  std::vector<double> sum_u, sum_v, count;
  for (std::int64_t v = 0; v < p.nv; ++v)
    for (std::int64_t r = s.runs.row_start[v]; r < s.runs.row_start[v + 1]; ++r) {
      std::int64_t& piece = piece_of[static_cast<std::size_t>(s.sets.find(r))];
      if (piece < 0) {
        piece = static_cast<std::int64_t>(count.size());
        sum_u.push_back(0.0);
        sum_v.push_back(0.0);
        count.push_back(0.0);
      }
      const auto n = static_cast<double>(runs[r].end - runs[r].begin);
      const auto c = static_cast<std::size_t>(piece);
      sum_u[c] += n * 0.5 * static_cast<double>(runs[r].begin + runs[r].end - 1);
      sum_v[c] += n * static_cast<double>(v);
      count[c] += n;
    }
  std::vector<Piece> pieces;
  for (std::size_t c = 0; c < count.size(); ++c)
    pieces.push_back(
        {sum_u[c] / count[c] * p.u_mm, sum_v[c] / count[c] * p.v_mm, count[c] * p.u_mm * p.v_mm});
  return pieces;
}

// What a ray from a piece's centre meets past its lumen, up to the largest radius.
struct Ray {
  const Plane* p;
  const Piece* piece;
  double du, dv, step;
  // The in-plane voxel t mm out along the ray, or none outside the scan.
  std::optional<std::size_t> at(double t) const {
    const auto u = static_cast<std::int64_t>(std::lround((piece->u_mm + t * du) / p->u_mm));
    const auto v = static_cast<std::int64_t>(std::lround((piece->v_mm + t * dv) / p->v_mm));
    if (u < 0 || u >= p->nu || v < 0 || v >= p->nv) return std::nullopt;
    return p->at(u, v);
  }
  Point point(double t, bool via_calcium) const {
    return {piece->u_mm + t * du, piece->v_mm + t * dv, via_calcium};
  }
};

struct Levels {
  double edge_hu, cortex_hu;
  bool bright(const CtVolume& ct, const Mask& cortex, std::size_t n) const {
    return cortex.data[n] || ct.data[n] >= cortex_hu;
  }
};

// Where the ray meets fat or air (see the header): the vessel's last voxel before it. Cortex met
// inside the vessel is a calcified flap or intima when, within kOutlineCalciumMm, the lumen goes
// on behind it (the ray goes on) or fat does (the edge, behind a calcified wall); else it is bone
// and the ray gives no point, as one that runs past the largest radius or out of the scan.
std::optional<Point> edge_point(const Ray& ray, const CtVolume& ct, const Mask& lumen,
                                const Mask& cortex, const Levels& lv, double max_radius_mm) {
  for (double t = 0.0; t <= max_radius_mm; t += ray.step) {
    const std::optional<std::size_t> n = ray.at(t);
    if (!n) return std::nullopt;
    if (lumen.data[*n]) continue;
    if (lv.bright(ct, cortex, *n)) {
      double behind = -1.0;
      bool fat = false;
      for (double s = ray.step; s <= kOutlineCalciumMm && behind < 0.0; s += ray.step) {
        const std::optional<std::size_t> m = ray.at(t + s);
        if (!m) break;
        fat = !lumen.data[*m] && !cortex.data[*m] && ct.data[*m] < lv.edge_hu;
        if (lumen.data[*m] || fat) behind = s;
      }
      if (behind < 0.0) return std::nullopt;
      if (fat) return ray.point(t + behind - ray.step, true);
      t += behind - ray.step;
      continue;
    }
    if (ct.data[*n] < lv.edge_hu) return ray.point(std::max(0.0, t - ray.step), false);
  }
  return std::nullopt;
}

std::vector<Point> edge_points(const Plane& p, const Piece& piece, const CtVolume& ct,
                               const Mask& lumen, const Mask& cortex, const Levels& lv,
                               double max_radius_mm) {
  const double step = 0.5 * std::min(p.u_mm, p.v_mm);
  std::vector<Point> points;
  for (int r = 0; r < kOutlineRays; ++r) {
    const double angle = 2.0 * kPi * r / kOutlineRays;
    const Ray ray{&p, &piece, std::cos(angle), std::sin(angle), step};
    if (const auto q = edge_point(ray, ct, lumen, cortex, lv, max_radius_mm)) points.push_back(*q);
  }
  return points;
}

// The least-squares circle through the points (Kasa's algebraic fit), with the RMS distance of the
// points from it; none when they are collinear.
std::optional<Circle> fit_circle(const std::vector<Point>& pts) {
  if (pts.size() < 3) return std::nullopt;
  const double n = static_cast<double>(pts.size());
  double mu = 0.0, mv = 0.0;
  for (const Point& q : pts) {
    mu += q.u / n;
    mv += q.v / n;
  }
  double suu = 0, svv = 0, suv = 0, suuu = 0, svvv = 0, suvv = 0, svuu = 0;
  for (const Point& q : pts) {
    const double a = q.u - mu, b = q.v - mv;
    suu += a * a;
    svv += b * b;
    suv += a * b;
    suuu += a * a * a;
    svvv += b * b * b;
    suvv += a * b * b;
    svuu += b * a * a;
  }
  const double det = suu * svv - suv * suv;
  if (std::abs(det) < 1e-9) return std::nullopt;
  const double b1 = 0.5 * (suuu + suvv), b2 = 0.5 * (svvv + svuu);
  const double uc = (b1 * svv - b2 * suv) / det, vc = (suu * b2 - suv * b1) / det;
  Circle c{uc + mu, vc + mv, std::sqrt(uc * uc + vc * vc + (suu + svv) / n), 0.0};
  double sq = 0.0;
  for (const Point& q : pts) {
    const double d = std::hypot(q.u - c.u, q.v - c.v) - c.radius;
    sq += d * d;
  }
  c.rms = std::sqrt(sq / n);
  return c;
}

// The vessel's circle from its edge points (see the header), or none.
std::optional<Circle> vessel_circle(std::vector<Point> pts, const VesselParams& params) {
  const auto enough = [&](std::size_t k) {
    return static_cast<double>(k) >= params.outline_min_edge_share * kOutlineRays;
  };
  if (!enough(pts.size())) return std::nullopt;
  std::optional<Circle> c = fit_circle(pts);
  for (int round = 0; round < 3 && c; ++round) {
    std::vector<Point> near;
    for (const Point& q : pts)
      if (std::abs(std::hypot(q.u - c->u, q.v - c->v) - c->radius) <= kOutlineOutlierMm)
        near.push_back(q);
    if (near.size() == pts.size()) break;
    if (!enough(near.size())) return std::nullopt;
    pts = std::move(near);
    c = fit_circle(pts);
  }
  std::size_t calcified = 0;
  for (const Point& q : pts) calcified += q.via_calcium;
  if (static_cast<double>(calcified) > kOutlineMaxCalcifiedShare * static_cast<double>(pts.size()))
    return std::nullopt;
  if (!c || c->radius < kOutlineMinRadiusMm || c->radius > params.outline_max_radius_mm ||
      c->rms > params.outline_max_rms_mm)
    return std::nullopt;
  return c;
}

// Appends to `added` what the lumen lacks inside the circle: tissue at or above the edge level
// (a voxel on the edge at least half vessel, by its HU: the wall's partial volume with the fat),
// and cortex (a calcified flap or intima) a voxel and a half in from the edge (the wall's own
// calcium stays out).
void fill_circle(const Plane& p, const Circle& c, const CtVolume& ct, const Mask& lumen,
                 const Mask& cortex, const Levels& lv, std::vector<std::size_t>& added) {
  const double hu = p.u_mm, hv = p.v_mm;
  const double voxel = std::min(hu, hv);
  const double reach = c.radius, calcium_reach = reach - 1.5 * voxel;
  const auto first = [](double lo, double h) {
    return std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor(lo / h)));
  };
  const auto last = [](double hi, double h, std::int64_t n) {
    return std::min<std::int64_t>(n - 1, static_cast<std::int64_t>(std::ceil(hi / h)));
  };
  for (std::int64_t v = first(c.v - reach, hv); v <= last(c.v + reach, hv, p.nv); ++v)
    for (std::int64_t u = first(c.u - reach, hu); u <= last(c.u + reach, hu, p.nu); ++u) {
      const double r =
          std::hypot(static_cast<double>(u) * hu - c.u, static_cast<double>(v) * hv - c.v);
      const std::size_t n = p.at(u, v);
      if (r > reach || lumen.data[n] || ct.data[n] < lv.edge_hu) continue;
      if (!lv.bright(ct, cortex, n) || r <= calcium_reach) added.push_back(n);
    }
}

}  // namespace

std::uint64_t fill_round_outlines(const CtVolume& ct, const Mask& cortex, double edge_hu,
                                  double cortex_hu, const VesselParams& params, Mask& lumen) {
  if (!(params.outline_max_radius_mm > 0.0)) return 0;
  const Grid& g = ct.grid;
  const PatientAxes axes = patient_axes(g);
  const Levels lv{edge_hu, cortex_hu};
  // per slice, the voxels its circles add (each slice's own, so no two chunks write one)
  std::vector<std::vector<std::size_t>> added(static_cast<std::size_t>(g.dims[axes.slice]));
  parallel_for_chunks(g.dims[axes.slice], 4, [&](std::int64_t w0, std::int64_t w1) {
    segmentation::PlaneScratch scratch;
    for (std::int64_t w = w0; w < w1; ++w) {
      const Plane p = index_ordered(segmentation::axial_plane(g, axes, w));
      for (const Piece& piece : pieces_in(p, lumen, scratch)) {
        if (piece.area_mm2 < kOutlineMinSectionMm2) continue;
        const std::optional<Circle> c = vessel_circle(
            edge_points(p, piece, ct, lumen, cortex, lv, params.outline_max_radius_mm), params);
        // the lumen fills a share of its vessel (a piece inside bone's marrow does not)
        if (c && piece.area_mm2 >= kOutlineMinLumenShare * kPi * c->radius * c->radius)
          fill_circle(p, *c, ct, lumen, cortex, lv, added[static_cast<std::size_t>(w)]);
      }
    }
  });
  std::uint64_t count = 0;
  for (const std::vector<std::size_t>& slice : added)
    for (const std::size_t n : slice) {
      count += lumen.data[n] == 0;  // two circles of one slice may hold a voxel both
      lumen.data[n] = 1;
    }
  return count;
}

}  // namespace palp
