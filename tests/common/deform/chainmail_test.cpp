// Tests for common/deform/chainmail.cpp: the links hold after every solve (checked here from the
// displacements and the parameters, independently of max_violation()), propagation is minimal
// with exact numbers in a known case and equals Gibson's neighbour-by-neighbour propagation,
// anchors are held exactly, incompatible anchors and anchors against the boundary give way as
// documented, and nothing outside the active box moves.
#include "deform/chainmail.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <random>
#include <span>
#include <vector>

#include "base/errors.hpp"

namespace palp {
namespace {

using Index3 = std::array<std::int64_t, 3>;

double comp(const Vec3d& v, int c) {
  return c == 0 ? v.x : (c == 1 ? v.y : v.z);
}

// Link bounds from the parameters (not from the class): [min, max] of component c of
// d_n - d_e for n = e + axis a.
double bound_min(const ChainMailParams& p, const std::array<double, 3>& h, int c, int a) {
  return c == a ? (p.min_stretch - 1.0) * h[a] : -p.max_shear * h[a];
}
double bound_max(const ChainMailParams& p, const std::array<double, 3>& h, int c, int a) {
  return c == a ? (p.max_stretch - 1.0) * h[a] : p.max_shear * h[a];
}

// The worst link violation, recomputed from displacement() alone.
double recomputed_violation(const ChainMail& mail) {
  const auto d = mail.dims();
  double worst = 0.0;
  for (std::int64_t k = 0; k < d[2]; ++k)
    for (std::int64_t j = 0; j < d[1]; ++j)
      for (std::int64_t i = 0; i < d[0]; ++i) {
        const Vec3d e = mail.displacement(i, j, k);
        const Index3 next[3] = {{i + 1, j, k}, {i, j + 1, k}, {i, j, k + 1}};
        for (int a = 0; a < 3; ++a) {
          if (next[a][a] >= d[a]) continue;
          const Vec3d n = mail.displacement(next[a][0], next[a][1], next[a][2]);
          for (int c = 0; c < 3; ++c) {
            const double diff = comp(n, c) - comp(e, c);
            worst = std::max({worst, bound_min(mail.params(), mail.spacing(), c, a) - diff,
                              diff - bound_max(mail.params(), mail.spacing(), c, a)});
          }
        }
      }
  return worst;
}

void expect_boundary_at_rest(const ChainMail& mail) {
  const auto d = mail.dims();
  for (std::int64_t k = 0; k < d[2]; ++k)
    for (std::int64_t j = 0; j < d[1]; ++j)
      for (std::int64_t i = 0; i < d[0]; ++i) {
        const bool boundary =
            i == 0 || j == 0 || k == 0 || i == d[0] - 1 || j == d[1] - 1 || k == d[2] - 1;
        if (boundary) {
          ASSERT_EQ(mail.displacement(i, j, k), Vec3d{}) << i << " " << j << " " << k;
        }
      }
}

void expect_zero_outside_active(const ChainMail& mail) {
  const auto d = mail.dims();
  const auto lo = mail.active_lo(), hi = mail.active_hi();
  for (std::int64_t k = 0; k < d[2]; ++k)
    for (std::int64_t j = 0; j < d[1]; ++j)
      for (std::int64_t i = 0; i < d[0]; ++i) {
        const bool inside =
            i >= lo[0] && i < hi[0] && j >= lo[1] && j < hi[1] && k >= lo[2] && k < hi[2];
        if (!inside) {
          ASSERT_EQ(mail.displacement(i, j, k), Vec3d{}) << i << " " << j << " " << k;
        }
      }
}

// Gibson's propagation, one neighbour at a time: pop an element, move each free neighbour the
// least distance into the box its link allows, queue it when it moved. The reference for
// propagate() (relaxation off).
std::vector<Vec3d> gibson_reference(const ChainMail& mail, std::span<const ChainMailAnchor> held) {
  const auto d = mail.dims();
  const auto& p = mail.params();
  const auto h = mail.spacing();
  auto index = [&](const Index3& e) { return e[0] + d[0] * (e[1] + d[1] * e[2]); };
  std::vector<Vec3d> disp(static_cast<std::size_t>(d[0] * d[1] * d[2]));
  std::vector<char> fixed(disp.size(), 0);
  std::deque<Index3> queue;
  for (const auto& anchor : held) {
    disp[index(anchor.element)] = anchor.displacement;
    fixed[index(anchor.element)] = 1;
    queue.push_back(anchor.element);
  }
  long pops = 0;
  while (!queue.empty() && ++pops < 50'000'000) {
    const Index3 e = queue.front();
    queue.pop_front();
    for (int a = 0; a < 3; ++a)
      for (int sign : {-1, 1}) {
        Index3 n = e;
        n[a] += sign;
        if (n[a] < 1 || n[a] > d[a] - 2) continue;  // the boundary stays at rest
        for (int b = 0; b < 3; ++b)
          if (n[b] < 1 || n[b] > d[b] - 2) n[0] = -1;
        if (n[0] < 0 || fixed[index(n)]) continue;
        Vec3d& dn = disp[index(n)];
        const Vec3d& de = disp[index(e)];
        bool moved = false;
        for (int c = 0; c < 3; ++c) {
          const double lo =
              sign > 0 ? comp(de, c) + bound_min(p, h, c, a) : comp(de, c) - bound_max(p, h, c, a);
          const double hi =
              sign > 0 ? comp(de, c) + bound_max(p, h, c, a) : comp(de, c) - bound_min(p, h, c, a);
          double& v = c == 0 ? dn.x : (c == 1 ? dn.y : dn.z);
          const double clamped = std::min(std::max(v, lo), hi);
          if (clamped != v) v = clamped, moved = true;
        }
        if (!moved) continue;
        queue.push_back(n);
        // Anchors next to n re-assert their links on it (they never move themselves).
        for (int b = 0; b < 3; ++b)
          for (int side : {-1, 1}) {
            Index3 m = n;
            m[b] += side;
            if (fixed[index(m)]) queue.push_back(m);
          }
      }
  }
  return disp;
}

TEST(ChainMail, RejectsBadParametersAndSizes) {
  EXPECT_THROW(ChainMail(ChainMailParams{1.2, 1.5, 0.5, 0, 0.5}), UsageError);
  EXPECT_THROW(ChainMail(ChainMailParams{0.5, 0.9, 0.5, 0, 0.5}), UsageError);
  EXPECT_THROW(ChainMail(ChainMailParams{0.5, 1.5, 0.0, 0, 0.5}), UsageError);
  EXPECT_THROW(ChainMail(ChainMailParams{0.5, 1.5, 0.5, -1, 0.5}), UsageError);
  EXPECT_THROW(ChainMail(ChainMailParams{0.5, 1.5, 0.5, 2, 1.5}), UsageError);
  ChainMail mail;
  EXPECT_THROW(mail.resize({0, 4, 4}, {1, 1, 1}), UsageError);
  EXPECT_THROW(mail.resize({4, 4, 4}, {1, -1, 1}), UsageError);
}

// A pull along +x at the centre of a large box: the element a links ahead (compressed) moves
// by max(0, D - a * (1 - min_stretch) h_x), behind (stretched) by max(0, D - a * (max_stretch -
// 1) h_x), sideways by the shear slack per link; x only. All numbers are exact in binary.
TEST(ChainMail, PropagationIsMinimalForAPull) {
  const ChainMailParams params{0.75, 1.5, 0.5, 0, 0.5};
  for (const std::array<double, 3> h :
       {std::array<double, 3>{1, 1, 1}, std::array<double, 3>{1, 2, 0.5}}) {
    ChainMail mail(params);
    mail.resize({31, 31, 31}, h);
    const double pull = 3.0;
    const ChainMailAnchor anchor{{15, 15, 15}, {pull, 0, 0}};
    const std::int64_t moved = mail.solve({&anchor, 1});
    std::int64_t expected_moved = 0;
    for (std::int64_t k = 0; k < 31; ++k)
      for (std::int64_t j = 0; j < 31; ++j)
        for (std::int64_t i = 0; i < 31; ++i) {
          const std::int64_t a = i - 15, b = j - 15, c = k - 15;
          const double cost = (a > 0 ? a * 0.25 * h[0] : -a * 0.5 * h[0]) +
                              std::abs(b) * 0.5 * h[1] + std::abs(c) * 0.5 * h[2];
          const double expected = std::max(0.0, pull - cost);
          const bool boundary = i == 0 || j == 0 || k == 0 || i == 30 || j == 30 || k == 30;
          const Vec3d got = mail.displacement(i, j, k);
          ASSERT_EQ(got, (Vec3d{boundary ? 0.0 : expected, 0, 0})) << i << " " << j << " " << k;
          if (expected > 0.0) ++expected_moved;
        }
    EXPECT_EQ(moved, expected_moved);
    // Spot values along the pull line, h = 1: 2.75 one link ahead, 2.5 one link behind.
    if (h[0] == 1.0) {
      EXPECT_EQ(mail.displacement(16, 15, 15).x, 2.75);
      EXPECT_EQ(mail.displacement(14, 15, 15).x, 2.5);
      EXPECT_EQ(mail.displacement(27, 15, 15).x, 0.0);
      EXPECT_EQ(mail.displacement(26, 15, 15).x, 0.25);
      EXPECT_EQ(mail.displacement(9, 15, 15).x, 0.0);
      EXPECT_EQ(mail.displacement(10, 15, 15).x, 0.5);
    }
    EXPECT_EQ(mail.max_violation(), 0.0);
    EXPECT_EQ(recomputed_violation(mail), 0.0);
    expect_zero_outside_active(mail);
  }
}

// Propagation equals the neighbour-by-neighbour propagation, for one anchor and for several
// compatible anchors pulling in different directions.
TEST(ChainMail, PropagationEqualsGibsonsPropagation) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> small(-1.5, 1.5);
  for (int trial = 0; trial < 6; ++trial) {
    ChainMail mail(ChainMailParams{0.5, 1.5, 0.5, 0, 0.5});
    mail.resize({23, 21, 19}, {1.0, 1.25, 1.5});
    std::vector<ChainMailAnchor> anchors;
    const int count = trial == 0 ? 1 : 2 + trial;
    for (int n = 0; n < count; ++n)
      anchors.push_back({{9 + n % 3, 8 + (n * 2) % 5, 8 + n % 2},
                         {3 * small(rng), 3 * small(rng), 3 * small(rng)}});
    mail.solve(anchors);
    const auto reference = gibson_reference(mail, mail.held_anchors());
    const auto d = mail.dims();
    double worst = 0.0;
    for (std::int64_t k = 0; k < d[2]; ++k)
      for (std::int64_t j = 0; j < d[1]; ++j)
        for (std::int64_t i = 0; i < d[0]; ++i) {
          const Vec3d diff = mail.displacement(i, j, k) - reference[i + d[0] * (j + d[1] * k)];
          worst = std::max(worst, norm(diff));
        }
    EXPECT_LE(worst, 1e-9) << "trial " << trial;
    EXPECT_LE(recomputed_violation(mail), 1e-9);
  }
}

// Links and held anchors after propagation and relaxation, for large displacements and
// anchors pulling apart, on default (soft tissue) parameters at 1.6 x 1.6 x 2 mm.
TEST(ChainMail, LinksHoldAfterSolve) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  ChainMail mail;  // defaults: relaxation on
  const std::array<double, 3> h{1.6, 1.6, 2.0};
  const std::vector<std::vector<ChainMailAnchor>> configurations = {
      {{{20, 20, 15}, {0, 0, -12}}},                                  // a deep press
      {{{20, 20, 15}, {9, -7, 5}}},                                   // large, oblique
      {{{16, 20, 15}, {-2, 0, -4}}, {{24, 20, 15}, {2, 0, -4}}},      // pulling apart
      {{{19, 20, 15}, {0.75, 0, 0}}, {{21, 20, 15}, {-0.75, 0, 0}}},  // squeezing together
      {{{20, 20, 15}, {0, 0, -8}}, {{20, 20, 16}, {0, 0, 8}}},        // incompatible pair
  };
  for (std::size_t n = 0; n < configurations.size() + 8; ++n) {
    std::vector<ChainMailAnchor> anchors;
    if (n < configurations.size()) {
      anchors = configurations[n];
    } else {  // random finger-like pads with friction drag
      const Vec3d press{3 * unit(rng), 3 * unit(rng), -6 + 4 * unit(rng)};
      for (int a = 0; a < 19; ++a)
        anchors.push_back(
            {{18 + a % 5, 18 + a / 5, 15}, press + Vec3d{unit(rng), unit(rng), 0.5 * unit(rng)}});
    }
    mail.resize({41, 41, 31}, h);
    mail.solve(anchors);
    EXPECT_LE(mail.max_violation(), 1e-9) << "configuration " << n;
    EXPECT_LE(recomputed_violation(mail), 1e-9) << "configuration " << n;
    EXPECT_NEAR(mail.max_violation(), recomputed_violation(mail), 1e-15);
    for (const auto& held : mail.held_anchors())
      EXPECT_EQ(mail.displacement(held.element[0], held.element[1], held.element[2]),
                held.displacement);
    expect_boundary_at_rest(mail);
    expect_zero_outside_active(mail);
    if (n < 4) {  // compatible: every anchor held as asked
      ASSERT_EQ(mail.held_anchors().size(), anchors.size());
      for (std::size_t a = 0; a < anchors.size(); ++a)
        EXPECT_EQ(mail.held_anchors()[a].displacement, anchors[a].displacement);
    }
  }
}

// Two neighbours along x asked to move 5 mm apart in x: the link allows [-0.5, 0.5] mm
// (h = 1), so the first is held and the second gives way to the nearest allowed value.
TEST(ChainMail, IncompatibleAnchorsEarlierWins) {
  ChainMail mail(ChainMailParams{0.5, 1.5, 0.5, 3, 0.5});
  mail.resize({31, 31, 31}, {1, 1, 1});
  const std::vector<ChainMailAnchor> anchors = {{{15, 15, 15}, {5, 0, 0}},
                                                {{16, 15, 15}, {-5, 0.25, 0}}};
  mail.solve(anchors);
  ASSERT_EQ(mail.held_anchors().size(), 2u);
  EXPECT_EQ(mail.held_anchors()[0].displacement, (Vec3d{5, 0, 0}));
  EXPECT_EQ(mail.held_anchors()[1].displacement, (Vec3d{4.5, 0.25, 0}));
  EXPECT_EQ(mail.displacement(16, 15, 15), (Vec3d{4.5, 0.25, 0}));
  EXPECT_LE(recomputed_violation(mail), 1e-9);

  // The other order: the other anchor wins.
  const std::vector<ChainMailAnchor> swapped = {anchors[1], anchors[0]};
  mail.solve(swapped);
  EXPECT_EQ(mail.held_anchors()[0].displacement, (Vec3d{-5, 0.25, 0}));
  EXPECT_EQ(mail.held_anchors()[1].displacement, (Vec3d{-4.5, 0, 0}));
  EXPECT_LE(recomputed_violation(mail), 1e-9);
}

// An anchor one element from the boundary can move at most one link's slack; anchors on the
// boundary or outside are dropped; anchors on one element hold their mean.
TEST(ChainMail, BoundaryLimitsDropsAndMerges) {
  ChainMail mail(ChainMailParams{0.5, 1.5, 0.5, 2, 0.5});
  mail.resize({12, 12, 12}, {2, 2, 2});
  std::vector<ChainMailAnchor> anchors = {{{1, 6, 6}, {5, -5, 0.25}},
                                          {{0, 6, 6}, {1, 1, 1}},
                                          {{6, 6, 12}, {1, 1, 1}},
                                          {{6, 6, 6}, {1, 2, -3}},
                                          {{6, 6, 6}, {2, 4, -1}}};
  mail.solve(anchors);
  ASSERT_EQ(mail.held_anchors().size(), 2u);
  // x at element 1 along x: the boundary at i = 0 allows 1 link of stretch: 0.5 * 2 mm = 1;
  // y: one link of shear to the i = 0 face: 1 mm.
  EXPECT_EQ(mail.held_anchors()[0].displacement, (Vec3d{1, -1, 0.25}));
  EXPECT_EQ(mail.held_anchors()[1].displacement, (Vec3d{1.5, 3, -2}));
  EXPECT_EQ(mail.displacement(6, 6, 6), (Vec3d{1.5, 3, -2}));
  EXPECT_LE(recomputed_violation(mail), 1e-9);
  expect_boundary_at_rest(mail);

  // Nothing held: everything at rest, nothing moved.
  const ChainMailAnchor outside{{-1, 3, 3}, {1, 1, 1}};
  EXPECT_EQ(mail.solve({&outside, 1}), 0);
  EXPECT_TRUE(mail.held_anchors().empty());
  EXPECT_EQ(recomputed_violation(mail), 0.0);
  EXPECT_EQ(mail.displacement(6, 6, 6), Vec3d{});
}

// Relaxation keeps the anchors and the links, stays in the active box and changes the minimal
// shape (it would be pointless otherwise); the result does not depend on what the box held.
TEST(ChainMail, RelaxationKeepsLinksAndIsRepeatable) {
  const ChainMailAnchor anchor{{12, 12, 12}, {0, 0, -5}};
  ChainMail minimal(ChainMailParams{0.5, 1.5, 0.5, 0, 0.5});
  minimal.resize({25, 25, 25}, {1, 1, 1});
  minimal.solve({&anchor, 1});
  ChainMail relaxed(ChainMailParams{0.5, 1.5, 0.5, 4, 0.5});
  relaxed.resize({25, 25, 25}, {1, 1, 1});
  const ChainMailAnchor other{{5, 5, 5}, {3, 3, 3}};
  relaxed.solve({&other, 1});
  relaxed.solve({&anchor, 1});
  EXPECT_LE(recomputed_violation(relaxed), 1e-9);
  EXPECT_EQ(relaxed.displacement(12, 12, 12), (Vec3d{0, 0, -5}));
  expect_zero_outside_active(relaxed);
  expect_boundary_at_rest(relaxed);
  int differs = 0;
  for (std::int64_t k = 0; k < 25; ++k)
    for (std::int64_t j = 0; j < 25; ++j)
      for (std::int64_t i = 0; i < 25; ++i)
        differs += relaxed.displacement(i, j, k) != minimal.displacement(i, j, k);
  EXPECT_GT(differs, 0);
  ChainMail fresh(ChainMailParams{0.5, 1.5, 0.5, 4, 0.5});
  fresh.resize({25, 25, 25}, {1, 1, 1});
  fresh.solve({&anchor, 1});
  for (std::int64_t k = 0; k < 25; ++k)
    for (std::int64_t j = 0; j < 25; ++j)
      for (std::int64_t i = 0; i < 25; ++i)
        ASSERT_EQ(fresh.displacement(i, j, k), relaxed.displacement(i, j, k));
}

// The reference relaxation: red-black Gauss-Seidel with the sweeps of `p` over the whole moved
// box of `propagated` (a solve without relaxation) grown by one element, clipped to the
// interior, every component, anchors skipped. relax() confines each pass to a component's
// nonzero box grown by one; that must give the same values bit for bit.
std::array<std::vector<double>, 3> reference_relax(const ChainMail& propagated,
                                                   const ChainMailParams& p) {
  const auto d = propagated.dims();
  const auto h = propagated.spacing();
  std::array<std::vector<double>, 3> disp;
  for (int c = 0; c < 3; ++c) {
    const auto v = propagated.displacement_component(c);
    disp[c].assign(v.begin(), v.end());
  }
  Index3 lo{}, hi{};
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::max<std::int64_t>(1, propagated.active_lo()[a] - 1);
    hi[a] = std::min<std::int64_t>(d[a] - 1, propagated.active_hi()[a] + 1);
  }
  std::vector<char> anchored(disp[0].size(), 0);
  for (const auto& anchor : propagated.held_anchors())
    anchored[anchor.element[0] + d[0] * (anchor.element[1] + d[1] * anchor.element[2])] = 1;
  const std::int64_t sj = d[0], sk = d[0] * d[1];
  for (int c = 0; c < 3; ++c) {
    double* v = disp[c].data();
    const auto lo_b = [&](int a) { return bound_min(p, h, c, a); };
    const auto hi_b = [&](int a) { return bound_max(p, h, c, a); };
    for (int sweep = 0; sweep < p.relax_iterations; ++sweep)
      for (int pass = 0; pass < 2; ++pass)
        for (std::int64_t k = lo[2]; k < hi[2]; ++k)
          for (std::int64_t j = lo[1]; j < hi[1]; ++j)
            for (std::int64_t i = lo[0]; i < hi[0]; ++i) {
              if (((i + j + k + sweep + pass) & 1) != 0) continue;
              const std::int64_t n = i + sj * j + sk * k;
              if (anchored[n]) continue;
              const double xm = v[n - 1], xp = v[n + 1], ym = v[n - sj], yp = v[n + sj];
              const double zm = v[n - sk], zp = v[n + sk];
              const double mean = (xm + xp + ym + yp + zm + zp) * (1.0 / 6.0);
              const double wanted = v[n] + p.relax_rate * (mean - v[n]);
              const double low = std::max(std::max(std::max(xm + lo_b(0), xp - hi_b(0)),
                                                   std::max(ym + lo_b(1), yp - hi_b(1))),
                                          std::max(zm + lo_b(2), zp - hi_b(2)));
              const double high = std::min(std::min(std::min(xm + hi_b(0), xp - lo_b(0)),
                                                    std::min(ym + hi_b(1), yp - lo_b(1))),
                                           std::min(zm + hi_b(2), zp - lo_b(2)));
              v[n] = std::min(std::max(wanted, low), high);
            }
  }
  return disp;
}

// A press along z with a small drag along x and none along y (so the three components move over
// boxes of very different sizes), at a fingertip-like anisotropic spacing: relax() (each
// component's own box, grown one element a pass) equals relaxing the whole box bit for bit, the
// y component stays exactly 0, and nothing moves outside the active box.
TEST(ChainMail, RelaxationOnEachComponentsBoxEqualsTheWholeBox) {
  const std::array<double, 3> h{1.6, 1.6, 1.0};
  const Index3 dims{34, 30, 40};
  const ChainMailAnchor anchors[] = {{{15, 14, 18}, {0.3, 0.0, -7.5}},
                                     {{17, 14, 18}, {0.25, 0.0, -7.0}},
                                     {{16, 15, 20}, {0.35, 0.0, -6.0}}};
  const ChainMailParams relax_params;  // the defaults: 4 sweeps at rate 0.5
  ChainMailParams minimal_params = relax_params;
  minimal_params.relax_iterations = 0;
  ChainMail minimal(minimal_params);
  minimal.resize(dims, h);
  minimal.solve(anchors);
  ChainMail relaxed(relax_params);
  relaxed.resize(dims, h);
  relaxed.solve(anchors);
  const auto want = reference_relax(minimal, relax_params);
  std::int64_t differ = 0, relax_moved = 0;
  for (int c = 0; c < 3; ++c) {
    const auto got = relaxed.displacement_component(c);
    const auto before = minimal.displacement_component(c);
    ASSERT_EQ(got.size(), want[c].size());
    for (std::size_t n = 0; n < got.size(); ++n) {
      differ += got[n] != want[c][n];
      relax_moved += got[n] != before[n];
    }
  }
  EXPECT_EQ(differ, 0);
  EXPECT_GT(relax_moved, 1000);  // the relaxation did something
  for (double v : relaxed.displacement_component(1)) ASSERT_EQ(v, 0.0);
  expect_zero_outside_active(relaxed);
  EXPECT_LE(recomputed_violation(relaxed), 1e-9);
}

// resize() to a new layout zeroes only the moved box: every element is at rest afterwards, in a
// smaller and in a larger box, and a solve there equals a fresh ChainMail's bit for bit, and a
// ChainMail that reserved more room than the box beforehand (the buffers never shrink).
TEST(ChainMail, ResizeToANewLayoutStartsAtRest) {
  const std::array<double, 3> h{1.6, 1.6, 1.0};
  ChainMail mail;
  mail.resize({30, 30, 30}, h);
  const ChainMailAnchor first{{14, 15, 16}, {2.0, -1.0, 5.0}};
  mail.solve({&first, 1});
  ASSERT_NE(mail.displacement(14, 15, 16), Vec3d{});
  for (const Index3 dims : {Index3{22, 26, 28}, Index3{36, 31, 33}}) {
    mail.resize(dims, h);
    for (int c = 0; c < 3; ++c)
      for (double v : mail.displacement_component(c)) ASSERT_EQ(v, 0.0);
    const ChainMailAnchor anchor{{10, 12, 13}, {-1.5, 0.5, 4.0}};
    mail.solve({&anchor, 1});
    ChainMail fresh, reserved;
    fresh.resize(dims, h);
    fresh.solve({&anchor, 1});
    reserved.reserve(std::size_t{1} << 16);  // more room than the box: the same result
    reserved.resize(dims, h);
    reserved.solve({&anchor, 1});
    for (int c = 0; c < 3; ++c) {
      const auto a = mail.displacement_component(c), b = fresh.displacement_component(c),
                 r = reserved.displacement_component(c);
      ASSERT_EQ(a.size(), static_cast<std::size_t>(dims[0] * dims[1] * dims[2]));
      ASSERT_EQ(a.size(), b.size());
      ASSERT_EQ(r.size(), b.size());
      for (std::size_t n = 0; n < a.size(); ++n) ASSERT_EQ(a[n], b[n]);
      for (std::size_t n = 0; n < r.size(); ++n) ASSERT_EQ(r[n], b[n]);
    }
    EXPECT_EQ(mail.active_lo(), fresh.active_lo());
    EXPECT_EQ(mail.active_hi(), fresh.active_hi());
  }
}

// The same press in two boxes that start one element apart in a larger lattice (a region of
// interest placed differently around the same anchors): with the origin given, the relaxation
// colours the elements alike and the displacements agree bit for bit, element for element.
TEST(ChainMail, TheBoxOriginDoesNotChangeTheRelaxation) {
  const std::array<double, 3> h{1.6, 1.6, 1.0};
  const Vec3d pressed{0.4, -0.3, -6.0};
  ChainMail a;
  a.resize({36, 36, 40}, h, {10, 20, 30});
  const ChainMailAnchor at_a{{18, 17, 20}, pressed};
  a.solve({&at_a, 1});
  ChainMail b;  // one more element before along i: everything sits one further along
  b.resize({37, 36, 40}, h, {9, 20, 30});
  const ChainMailAnchor at_b{{19, 17, 20}, pressed};
  b.solve({&at_b, 1});
  std::int64_t moved = 0;
  for (std::int64_t k = 0; k < 40; ++k)
    for (std::int64_t j = 0; j < 36; ++j)
      for (std::int64_t i = 0; i < 36; ++i) {
        ASSERT_EQ(a.displacement(i, j, k), b.displacement(i + 1, j, k))
            << i << " " << j << " " << k;
        moved += a.displacement(i, j, k) != Vec3d{};
      }
  EXPECT_GT(moved, 1000);
  // Without the origin the colours swap, and the relaxation (not the links) differs slightly.
  ChainMail c;
  c.resize({37, 36, 40}, h);
  c.solve({&at_b, 1});
  std::int64_t differ = 0;
  for (std::int64_t k = 0; k < 40; ++k)
    for (std::int64_t j = 0; j < 36; ++j)
      for (std::int64_t i = 0; i < 36; ++i)
        differ += a.displacement(i, j, k) != c.displacement(i + 1, j, k);
  EXPECT_GT(differ, 0);
}

}  // namespace
}  // namespace palp
