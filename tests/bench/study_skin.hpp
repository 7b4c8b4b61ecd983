// The skin of a real CT for the smoothness study (study_force_model, part 3): the trilinearly
// interpolated HU, its -500 HU iso-surface, and the global distance to that surface's skin sheet
// near a path, on which the study places its pad at a constant true depth. Measures only.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <tuple>
#include <vector>

#include "base/vec.hpp"
#include "base/volume.hpp"
#include "bench/study_util.hpp"
#include "prep/maps/iso_projection.hpp"

namespace palp::study {

// Calls fn(node, w) for the 8 nodes of grid g (voxel (i,j,k) at (i sx, j sy, k sz)) around p,
// w their trilinear weights at p.
template <class Fn>
void for_each_node_around(const Grid& g, const Vec3d& p, Fn fn) {
  const double u[3] = {p.x / g.spacing[0], p.y / g.spacing[1], p.z / g.spacing[2]};
  double t[3], base[3];
  for (int a = 0; a < 3; ++a) {
    base[a] = std::floor(u[a]);
    t[a] = u[a] - base[a];
  }
  for (int c = 0; c < 8; ++c) {
    const int b[3] = {c & 1, (c >> 1) & 1, c >> 2};
    double w = 1.0;
    for (int a = 0; a < 3; ++a) w *= b[a] ? t[a] : 1.0 - t[a];
    fn(Vec3d{(base[0] + b[0]) * g.spacing[0], (base[1] + b[1]) * g.spacing[1],
             (base[2] + b[2]) * g.spacing[2]},
       w);
  }
}

struct Hu {
  CtVolume ct;
  double at(const Vec3d& x) const {
    const Grid& g = ct.grid;
    const double u[3] = {x.x / g.spacing[0], x.y / g.spacing[1], x.z / g.spacing[2]};
    std::int64_t i0[3];
    double t[3];
    for (int a = 0; a < 3; ++a) {
      const double c = std::clamp(u[a], 0.0, static_cast<double>(g.dims[a] - 1) - 1e-9);
      i0[a] = static_cast<std::int64_t>(c);
      t[a] = c - static_cast<double>(i0[a]);
    }
    double v = 0.0;
    for (int c = 0; c < 8; ++c) {
      const std::int64_t i = i0[0] + (c & 1), j = i0[1] + ((c >> 1) & 1), k = i0[2] + (c >> 2);
      const double w = ((c & 1) ? t[0] : 1 - t[0]) * (((c >> 1) & 1) ? t[1] : 1 - t[1]) *
                       ((c >> 2) ? t[2] : 1 - t[2]);
      v += w * ct.at(i, j, k);
    }
    return v;
  }
  Vec3d normal(const Vec3d& x) const {  // outward: -grad HU, central differences over 1.5 mm
    const double h = 1.5;
    const Vec3d g{at(x + Vec3d{h, 0, 0}) - at(x - Vec3d{h, 0, 0}),
                  at(x + Vec3d{0, h, 0}) - at(x - Vec3d{0, h, 0}),
                  at(x + Vec3d{0, 0, h}) - at(x - Vec3d{0, 0, h})};
    return normalized(-1.0 * g);
  }
  // The distance from p to the -500 HU iso-surface (prep/maps/iso_projection.hpp), from a surface
  // point near its nearest one; signed as the maps are (positive inside, where HU >= -500).
  double distance(const Vec3d& p, const Vec3d& near) const {
    const double q[3] = {p.x, p.y, p.z};
    double x[3] = {near.x, near.y, near.z};
    const double d = distance_to_iso_surface(ct, -500.0, q, x);
    return at(p) >= -500.0 ? d : -d;
  }
  // The trilinear interpolation at p of the exact distances `dist` at the 8 nodes of grid g (the
  // maps') around it.
  template <class Distance>
  static double interpolated_node_distance(const Grid& g, const Vec3d& p, Distance dist) {
    double out = 0.0;
    for_each_node_around(g, p, [&](const Vec3d& node, double w) { out += w * dist(node); });
    return out;
  }
  // The -500 HU crossing met coming in along -dir from `outside` (bisection to 1e-6 mm): from
  // outside, so that gas in the bowel is not taken for the skin.
  Vec3d skin(const Vec3d& outside, const Vec3d& dir) const {
    double lo = 0.0, hi = 0.0;  // at(outside - lo dir) < -500 <= at(outside - hi dir)
    while (at(outside - hi * dir) < -500.0 && hi < 100.0) lo = hi, hi += 0.25;
    for (int i = 0; i < 40; ++i) {
      const double mid = 0.5 * (lo + hi);
      (at(outside - mid * dir) < -500.0 ? lo : hi) = mid;
    }
    return outside - (0.5 * (lo + hi)) * dir;
  }
};

// The skin sheet of the iso-surface around a path that runs along `superior` at the ray's
// crossings: the crossings of rays parallel to `ray`, met from outside, on a 1 mm grid of
// (along, across) offsets reaching `margin` mm beyond the path on every side. global(p) is the
// distance from p to that sheet: prep's closest-point descent (distance_to_iso_surface) started
// from every sample that is a local minimum of |p - sample| over the grid within 1 mm of the
// nearest (one per basin, so the descent cannot stay on the wrong sheet of a fold), the least
// of them, refined by a second descent from its closest point. Being a minimum over the sheet
// it is 1-Lipschitz in p, hence continuous, where prep's single descent from one start point may
// jump between two local closest points.
class SkinSheet {
 public:
  // `origin(a)`: a point outside the body on the ray through the path's point `a` mm along it
  // (a in [-margin, length + margin]).
  template <class Origin>
  SkinSheet(const Hu& hu, Origin origin, const Vec3d& ray, const Vec3d& superior, double length,
            double margin)
      : hu_(hu), superior_(superior), margin_(margin) {
    const Vec3d across = normalized(cross(ray, superior));
    na_ = static_cast<int>(std::ceil(length + 2 * margin)) + 1;
    nb_ = static_cast<int>(2 * margin) + 1;
    pts_.resize(static_cast<std::size_t>(na_) * nb_);
    for (int i = 0; i < na_; ++i) {
      const Vec3d o = origin(i - margin);
      if (i == 0) start_ = o;
      for (int j = 0; j < nb_; ++j) pts_[idx(i, j)] = hu.skin(o + (j - margin) * across, ray);
    }
    base_ = dot(start_, superior_);
  }

  // The signed distance (positive inside, HU >= -500) from p to the sheet; *foot: its closest
  // point.
  double global(const Vec3d& p, Vec3d* foot = nullptr) const {
    const int centre = static_cast<int>(std::lround(dot(p, superior_) - base_));
    const int i0 = std::max(0, centre - kWindow), i1 = std::min(na_ - 1, centre + kWindow);
    std::vector<double> d(static_cast<std::size_t>(na_) * nb_, 0.0);
    double nearest = std::numeric_limits<double>::infinity();
    for (int i = i0; i <= i1; ++i)
      for (int j = 0; j < nb_; ++j) {
        d[idx(i, j)] = norm(p - pts_[idx(i, j)]);
        nearest = std::min(nearest, d[idx(i, j)]);
      }
    double best = std::numeric_limits<double>::infinity();
    Vec3d best_x = p;
    const auto descend = [&](const Vec3d& from) {
      const double q[3] = {p.x, p.y, p.z};
      double x[3] = {from.x, from.y, from.z};
      const double dist = distance_to_iso_surface(hu_.ct, -500.0, q, x);
      if (dist >= 0.0 && dist < best) best = dist, best_x = Vec3d{x[0], x[1], x[2]};
    };
    for (int i = i0; i <= i1; ++i)
      for (int j = 0; j < nb_; ++j) {
        const double v = d[idx(i, j)];
        if (v > nearest + 1.0) continue;
        bool minimum = true;
        for (int di = -1; di <= 1 && minimum; ++di)
          for (int dj = -1; dj <= 1; ++dj) {
            const int a = i + di, b = j + dj;
            if ((di || dj) && a >= i0 && a <= i1 && b >= 0 && b < nb_ && d[idx(a, b)] < v) {
              minimum = false;
              break;
            }
          }
        if (minimum) descend(pts_[idx(i, j)]);
      }
    descend(best_x);  // a second descent, from the best closest point, with its step reset
    if (foot) *foot = best_x;
    return hu_.at(p) >= -500.0 ? best : -best;
  }

  // The same distance, memoised by point (for grid nodes met again and again).
  double global_cached(const Vec3d& p) const {
    const auto key = std::make_tuple(p.x, p.y, p.z);
    const auto it = cache_.find(key);
    if (it != cache_.end()) return it->second;
    return cache_[key] = global(p);
  }

  // A brute-force reference: the iso-surface sampled by bisection on every grid line of spacing
  // `h` in the cube of half-side `half` around p (along each of the three axes, HU sampled every
  // h / 2), the least distance from p to those crossings. Every sample lies on the surface, so
  // it bounds the distance from above, within about (h / 2)^2 / (2 d) of it.
  double brute_force(const Vec3d& p, double half, double h) const {
    double best = std::numeric_limits<double>::infinity();
    const int n = static_cast<int>(std::ceil(half / h));
    const int m = static_cast<int>(std::ceil(2 * half / (0.5 * h)));
    for (int axis = 0; axis < 3; ++axis) {
      Vec3d e{0, 0, 0}, u{0, 0, 0}, w{0, 0, 0};
      (axis == 0 ? e.x : axis == 1 ? e.y : e.z) = 1.0;
      (axis == 0 ? u.y : axis == 1 ? u.z : u.x) = 1.0;
      (axis == 0 ? w.z : axis == 1 ? w.x : w.y) = 1.0;
      for (int a = -n; a <= n; ++a)
        for (int b = -n; b <= n; ++b) {
          const Vec3d line = p + (a * h) * u + (b * h) * w - half * e;
          double prev = hu_.at(line) + 500.0;
          for (int k = 1; k <= m; ++k) {
            const double s = k * 0.5 * h;
            const double cur = hu_.at(line + s * e) + 500.0;
            if ((prev >= 0.0) != (cur >= 0.0)) {
              double lo = s - 0.5 * h, hi = s;
              for (int it = 0; it < 40; ++it) {
                const double mid = 0.5 * (lo + hi);
                ((hu_.at(line + mid * e) + 500.0 >= 0.0) == (prev >= 0.0) ? lo : hi) = mid;
              }
              best = std::min(best, norm(p - (line + (0.5 * (lo + hi)) * e)));
            }
            prev = cur;
          }
        }
    }
    return best;
  }

 private:
  static constexpr int kWindow = 15;  // mm along the path searched each side of p
  std::size_t idx(int i, int j) const { return static_cast<std::size_t>(i) * nb_ + j; }
  const Hu& hu_;
  Vec3d superior_, start_;
  double margin_ = 0.0, base_ = 0.0;
  int na_ = 0, nb_ = 0;
  std::vector<Vec3d> pts_;
  mutable std::map<std::tuple<double, double, double>, double> cache_;
};

}  // namespace palp::study
