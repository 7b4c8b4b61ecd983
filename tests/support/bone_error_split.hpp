// Where a bone mask disagrees with expert labels: the false negatives and false positives split by
// HU, by how far they lie from the other mask (a one-voxel rim vs detached), by region of the body
// and by connected piece, and the mean surface distance split by how far each surface voxel lies
// from the other surface. A diagnostic for tests/common/prep/bone/bone_segmentation_test.cpp
// (PALP_BONE_DIAG=1); it prints, it asserts nothing.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "base/volume.hpp"
#include "prep/segment/segmentation.hpp"
#include "support/mask_metrics.hpp"

namespace palp::testing {

// Whether voxel (i, j, k) has a face neighbour set in `m`.
inline bool touches(const Mask& m, std::int64_t i, std::int64_t j, std::int64_t k) {
  const Grid& g = m.grid;
  const Index3 next[6] = {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k},
                          {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}};
  for (const Index3& q : next)
    if (g.contains(q[0], q[1], q[2]) && m.at(q[0], q[1], q[2])) return true;
  return false;
}

// Region of a voxel: superficial anterolateral (within 30 mm of the outside, not in the posterior
// 30 % of its slice: ribs, cartilage, iliac crests), posterior (the spine's part of the slice), or
// deep (the rest: vertebral bodies, pelvis, femora).
enum class Region { superficial = 0, posterior = 1, deep = 2 };

inline std::vector<std::uint8_t> body_regions(const Mask& body) {
  const Grid& g = body.grid;
  const PatientAxes axes = patient_axes(g);
  Mask outside = body;
  for (auto& v : outside.data) v = v ? 0 : 1;
  const std::vector<double> to_outside = squared_distance_to(outside);
  std::vector<std::uint8_t> region(body.size(), static_cast<std::uint8_t>(Region::deep));
  for (std::int64_t s = 0; s < g.dims[axes.slice]; ++s) {
    std::int64_t lo = g.dims[axes.posterior], hi = -1;
    Index3 at{};
    at[axes.slice] = s;
    auto each = [&](auto fn) {
      for (std::int64_t p = 0; p < g.dims[axes.posterior]; ++p)
        for (std::int64_t l = 0; l < g.dims[axes.lateral]; ++l) {
          at[axes.posterior] = p;
          at[axes.lateral] = l;
          fn(p, g.linear(at[0], at[1], at[2]));
        }
    };
    each([&](std::int64_t p, std::size_t n) {
      if (body.data[n]) lo = std::min(lo, p), hi = std::max(hi, p);
    });
    if (hi < 0) continue;
    const double extent = static_cast<double>(hi - lo);
    each([&](std::int64_t p, std::size_t n) {
      const double back =
          axes.posterior_increasing ? static_cast<double>(p - lo) : static_cast<double>(hi - p);
      if (back > 0.7 * extent)
        region[n] = static_cast<std::uint8_t>(Region::posterior);
      else if (to_outside[n] <= 30.0 * 30.0)
        region[n] = static_cast<std::uint8_t>(Region::superficial);
    });
  }
  return region;
}

inline void print_bone_error_split(const CtVolume& ct, const Mask& body, const Mask& ours,
                                   const Mask& truth) {
  const Grid& g = ct.grid;
  const std::vector<std::uint8_t> region = body_regions(body);
  const int edges[] = {-100, 0, 50, 100, 150, 200, 300, 500};
  constexpr int kBins = 9;
  auto bin_of = [&](int hu) {
    int b = 0;
    while (b < 8 && hu >= edges[b]) ++b;
    return b;
  };
  // [kind 0 FN rim, 1 FN detached, 2 FP rim, 3 FP detached][region][bin]
  std::int64_t c[4][3][kBins] = {};
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const std::size_t n = g.linear(i, j, k);
        const bool o = ours.data[n], t = truth.data[n];
        if (o == t) continue;
        const int kind = t ? (touches(ours, i, j, k) ? 0 : 1) : (touches(truth, i, j, k) ? 2 : 3);
        ++c[kind][region[n]][bin_of(ct.data[n])];
      }
  const char* kinds[] = {"FN next to ours", "FN detached", "FP next to truth", "FP detached"};
  const char* regions[] = {"superficial", "posterior", "deep"};
  std::printf("| error | region | <-100 | -100 | 0 | 50 | 100 | 150 | 200 | 300 | >=500 | sum |\n");
  for (int kd = 0; kd < 4; ++kd)
    for (int r = 0; r < 3; ++r) {
      std::int64_t sum = 0;
      std::printf("| %s | %s |", kinds[kd], regions[r]);
      for (int b = 0; b < kBins; ++b)
        std::printf(" %lld |", static_cast<long long>(c[kd][r][b])), sum += c[kd][r][b];
      std::printf(" %lld |\n", static_cast<long long>(sum));
    }
  // Surface distances: each surface voxel's distance to the other surface, by bands.
  const Mask so = surface(ours), st = surface(truth);
  const std::vector<double> to_o = squared_distance_to(so), to_t = squared_distance_to(st);
  const double bands[] = {0.5, 3.1, 4.5, 6.1, 12.1, 1e9};
  double sum_band[2][6] = {}, cnt_band[2][6] = {};
  double total = 0, count = 0;
  for (std::size_t n = 0; n < so.size(); ++n)
    for (int side = 0; side < 2; ++side) {
      if (!(side == 0 ? so.data[n] : st.data[n])) continue;
      const double d = std::sqrt(side == 0 ? to_t[n] : to_o[n]);
      int b = 0;
      while (d > bands[b]) ++b;
      sum_band[side][b] += d, cnt_band[side][b] += 1, total += d, count += 1;
    }
  std::printf("surface voxels: ours %.0f, truth's %.0f; ASSD %.3f mm\n",
              cnt_band[0][0] + cnt_band[0][1] + cnt_band[0][2] + cnt_band[0][3] + cnt_band[0][4] +
                  cnt_band[0][5],
              cnt_band[1][0] + cnt_band[1][1] + cnt_band[1][2] + cnt_band[1][3] + cnt_band[1][4] +
                  cnt_band[1][5],
              total / count);
  const char* band_names[] = {"0", "<=3.1", "<=4.5", "<=6.1", "<=12.1", ">12.1"};
  for (int side = 0; side < 2; ++side)
    for (int b = 0; b < 6; ++b)
      std::printf("  %s surface at %s mm: %.0f voxels, %.3f mm of the ASSD\n",
                  side == 0 ? "our" : "truth's", band_names[b], cnt_band[side][b],
                  sum_band[side][b] / count);
  // Boundary HU: our surface voxels and truth's, with the mean HU of their outside neighbours.
  for (int side = 0; side < 2; ++side) {
    const Mask& m = side == 0 ? ours : truth;
    const Mask& s = side == 0 ? so : st;
    std::vector<int> in_hu, out_hu;
    for (std::int64_t k = 0; k < g.dims[2]; ++k)
      for (std::int64_t j = 0; j < g.dims[1]; ++j)
        for (std::int64_t i = 0; i < g.dims[0]; ++i) {
          if (!s.at(i, j, k)) continue;
          in_hu.push_back(ct.at(i, j, k));
          const Index3 next[6] = {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k},
                                  {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}};
          for (const Index3& q : next)
            if (g.contains(q[0], q[1], q[2]) && !m.at(q[0], q[1], q[2]))
              out_hu.push_back(ct.at(q[0], q[1], q[2]));
        }
    auto pct = [](std::vector<int> v, double p) {
      std::sort(v.begin(), v.end());
      return v.empty() ? 0 : v[static_cast<std::size_t>(p * (v.size() - 1))];
    };
    std::printf("%s surface HU: inside p10/50/90 %d/%d/%d, outside neighbours %d/%d/%d\n",
                side == 0 ? "our" : "truth's", pct(in_hu, 0.1), pct(in_hu, 0.5), pct(in_hu, 0.9),
                pct(out_hu, 0.1), pct(out_hu, 0.5), pct(out_hu, 0.9));
  }
}

// The largest 6-connected pieces of `a` and not `b`: size, mean and max HU, bounding box.
inline void print_pieces(const CtVolume& ct, const Mask& a, const Mask& b, const char* name,
                         int how_many) {
  const Grid& g = a.grid;
  std::vector<std::int32_t> label(a.size(), -1);
  struct Piece {
    std::int64_t n = 0;
    double hu = 0;
    int max_hu = -2000;
    std::int64_t lo[3] = {1 << 30, 1 << 30, 1 << 30}, hi[3] = {-1, -1, -1};
    std::int64_t touching_b = 0;
  };
  std::vector<Piece> pieces;
  std::vector<Index3> stack;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const std::size_t n0 = g.linear(i, j, k);
        if (!a.data[n0] || b.data[n0] || label[n0] >= 0) continue;
        Piece p;
        const auto id = static_cast<std::int32_t>(pieces.size());
        label[n0] = id;
        stack.push_back({i, j, k});
        while (!stack.empty()) {
          const Index3 q = stack.back();
          stack.pop_back();
          const std::size_t n = g.linear(q[0], q[1], q[2]);
          ++p.n;
          p.hu += ct.data[n];
          p.max_hu = std::max(p.max_hu, static_cast<int>(ct.data[n]));
          for (int d = 0; d < 3; ++d)
            p.lo[d] = std::min(p.lo[d], q[d]), p.hi[d] = std::max(p.hi[d], q[d]);
          if (touches(b, q[0], q[1], q[2])) ++p.touching_b;
          const Index3 next[6] = {{q[0] - 1, q[1], q[2]}, {q[0] + 1, q[1], q[2]},
                                  {q[0], q[1] - 1, q[2]}, {q[0], q[1] + 1, q[2]},
                                  {q[0], q[1], q[2] - 1}, {q[0], q[1], q[2] + 1}};
          for (const Index3& r : next) {
            if (!g.contains(r[0], r[1], r[2])) continue;
            const std::size_t m = g.linear(r[0], r[1], r[2]);
            if (a.data[m] && !b.data[m] && label[m] < 0) label[m] = id, stack.push_back(r);
          }
        }
        pieces.push_back(p);
      }
  std::sort(pieces.begin(), pieces.end(), [](const Piece& x, const Piece& y) { return x.n > y.n; });
  std::printf("%s: %zu pieces\n", name, pieces.size());
  for (int t = 0; t < how_many && t < static_cast<int>(pieces.size()); ++t) {
    const Piece& p = pieces[static_cast<std::size_t>(t)];
    std::printf(
        "  %lld voxels (%lld touching), mean %.0f max %d HU, i %lld-%lld j %lld-%lld k %lld-%lld\n",
        static_cast<long long>(p.n), static_cast<long long>(p.touching_b), p.hu / p.n, p.max_hu,
        static_cast<long long>(p.lo[0]), static_cast<long long>(p.hi[0]),
        static_cast<long long>(p.lo[1]), static_cast<long long>(p.hi[1]),
        static_cast<long long>(p.lo[2]), static_cast<long long>(p.hi[2]));
  }
}

}  // namespace palp::testing
