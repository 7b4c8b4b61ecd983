// 3D ChainMail with elastic relaxation (see chainmail.hpp for the constraints and data flow).
//
// Propagation. For one component c the links say d_n - d_e in [m_a, M_a] for n = e + a
// (m_a = link_min(c, a), M_a = link_max(c, a); m_a < 0 < M_a). Given held values v_f at the
// anchors, every solution satisfies lower(n) <= d_n <= upper(n) with
//   upper(n) = min_f v_f + S(f -> n),   lower(n) = max_f v_f - S(n -> f),
// S the weighted L1 chain slack (M_a per link up along a, -m_a per link down). Gibson's
// propagation moves each element the least distance that satisfies its sponsor, so its fixpoint
// is the solution nearest rest, clamp(0, lower, upper) (min and max of functions that satisfy
// the links satisfy them too, so it is a solution, and every solution lies in [lower, upper]).
// min(0, upper) is the min-plus transform of "v at anchors, 0 elsewhere" by S, and max(0, lower)
// likewise; S is separable, so each is two 1D sweeps per axis (forward and backward), exact.
// The boundary, held at 0, needs no sweep: hold_anchors() makes the anchors compatible with it,
// and then its bounds never decide clamp(0, lower, upper).
#include "deform/chainmail.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "base/errors.hpp"

namespace palp {

namespace {

using Index3 = std::array<std::int64_t, 3>;

double component(const Vec3d& v, int c) {
  return c == 0 ? v.x : (c == 1 ? v.y : v.z);
}
void set_component(Vec3d& v, int c, double value) {
  (c == 0 ? v.x : (c == 1 ? v.y : v.z)) = value;
}

}  // namespace

ChainMail::ChainMail(ChainMailParams params) : params_(params) {
  if (!(params_.min_stretch > 0.0 && params_.min_stretch <= 1.0) ||
      !(params_.max_stretch >= 1.0 && std::isfinite(params_.max_stretch)) ||
      !(params_.max_shear > 0.0 && std::isfinite(params_.max_shear)) ||
      params_.relax_iterations < 0 || !(params_.relax_rate >= 0.0 && params_.relax_rate <= 1.0))
    throw UsageError(
        "chainmail: parameters out of range (need 0 < min_stretch <= 1 <= "
        "max_stretch, max_shear > 0, relax_iterations >= 0, 0 <= relax_rate <= 1)");
  if (params_.min_stretch == 1.0 && params_.max_stretch == 1.0)
    throw UsageError("chainmail: min_stretch = max_stretch = 1 leaves no slack to deform");
}

void ChainMail::resize(std::array<std::int64_t, 3> dims, std::array<double, 3> h,
                       std::array<std::int64_t, 3> origin) {
  for (int a = 0; a < 3; ++a) {
    if (dims[a] <= 0) throw UsageError("chainmail: box dimensions must be positive");
    if (!(h[a] > 0.0 && std::isfinite(h[a])))
      throw UsageError("chainmail: spacing must be positive and finite");
  }
  // Every displacement is 0 outside the active box, so
  // zeroing the active box (in the old layout) leaves every stored value 0 and a new layout
  // needs no pass over the whole box: what the vectors gain is value-initialised (0). The cost
  // is the moved box, not the ROI, and the allocation is kept when the box shrinks.
  reset();
  dims_ = dims;
  h_ = h;
  origin_parity_ = (origin[0] + origin[1] + origin[2]) & 1;
  for (int c = 0; c < 3; ++c)
    for (int a = 0; a < 3; ++a) {
      link_min_[c][a] = c == a ? (params_.min_stretch - 1.0) * h[a] : -params_.max_shear * h[a];
      link_max_[c][a] = c == a ? (params_.max_stretch - 1.0) * h[a] : params_.max_shear * h[a];
    }
  count_ = static_cast<std::size_t>(dims[0] * dims[1] * dims[2]);
  reserve(count_);  // the buffers never shrink: a box that grows back costs no zeroing
}

void ChainMail::reserve(std::size_t elements) {
  if (disp_[0].size() >= elements) return;
  for (auto& d : disp_) d.resize(elements, 0.0);  // beyond the box: 0, as the box's own
  upper_.resize(elements);
  lower_.resize(elements);
}

void ChainMail::reset() {
  zero_box(active_lo_, active_hi_);
  active_lo_ = active_hi_ = {};
}

void ChainMail::zero_box(Index3 lo, Index3 hi) {
  if (lo[0] >= hi[0] || lo[1] >= hi[1] || lo[2] >= hi[2]) return;
  for (auto& d : disp_)
    for (std::int64_t k = lo[2]; k < hi[2]; ++k)
      for (std::int64_t j = lo[1]; j < hi[1]; ++j) {
        double* row = d.data() + index(0, j, k);
        std::fill(row + lo[0], row + hi[0], 0.0);
      }
}

Vec3d ChainMail::displacement(std::int64_t i, std::int64_t j, std::int64_t k) const {
  const auto n = index(i, j, k);
  return {disp_[0][n], disp_[1][n], disp_[2][n]};
}

double ChainMail::chain_slack(int c, const Index3& from, const Index3& to) const {
  double slack = 0.0;
  for (int a = 0; a < 3; ++a) {
    const auto delta = to[a] - from[a];
    slack += delta > 0 ? delta * link_max_[c][a] : -delta * -link_min_[c][a];
  }
  return slack;
}

std::int64_t ChainMail::solve(std::span<const ChainMailAnchor> anchors) {
  reset();
  hold_anchors(anchors);
  if (held_.empty()) return 0;
  const std::int64_t moved = propagate();
  relax();
  return moved;
}

void ChainMail::hold_anchors(std::span<const ChainMailAnchor> anchors) {
  held_.clear();
  held_weight_.clear();
  for (const auto& anchor : anchors) {
    bool interior = is_finite(anchor.displacement);
    for (int a = 0; a < 3; ++a)
      interior = interior && anchor.element[a] >= 1 && anchor.element[a] <= dims_[a] - 2;
    if (!interior) continue;
    std::size_t slot = 0;
    while (slot < held_.size() && held_[slot].element != anchor.element) ++slot;
    if (slot == held_.size()) {
      held_.push_back({anchor.element, {}});
      held_weight_.push_back(0);
    }
    held_[slot].displacement += anchor.displacement;
    ++held_weight_[slot];
  }
  for (std::size_t g = 0; g < held_.size(); ++g) {
    ChainMailAnchor& anchor = held_[g];
    if (held_weight_[g] > 1) anchor.displacement *= 1.0 / static_cast<double>(held_weight_[g]);
    const Index3& e = anchor.element;
    for (int c = 0; c < 3; ++c) {
      // The boundary (at 0) allows v <= S(boundary -> e) and v >= -S(e -> boundary).
      double hi = std::numeric_limits<double>::infinity();
      double lo = -hi;
      for (int a = 0; a < 3; ++a) {
        const auto to_low = static_cast<double>(e[a]);
        const auto to_high = static_cast<double>(dims_[a] - 1 - e[a]);
        hi = std::min({hi, to_low * link_max_[c][a], to_high * -link_min_[c][a]});
        lo = std::max({lo, -to_low * -link_min_[c][a], -to_high * link_max_[c][a]});
      }
      for (std::size_t f = 0; f < g; ++f) {
        const double vf = component(held_[f].displacement, c);
        hi = std::min(hi, vf + chain_slack(c, held_[f].element, e));
        lo = std::max(lo, vf - chain_slack(c, e, held_[f].element));
      }
      set_component(anchor.displacement, c,
                    std::min(std::max(component(anchor.displacement, c), lo), hi));
    }
  }
}

std::int64_t ChainMail::propagate() {
  std::array<Index3, 3> comp_lo{}, comp_hi{};
  Index3 lo{}, hi{};
  influence_boxes(comp_lo, comp_hi, lo, hi);
  for (int c = 0; c < 3; ++c) propagate_component(c, comp_lo[c], comp_hi[c]);
  return measure_moved(lo, hi);
}

void ChainMail::influence_boxes(std::array<Index3, 3>& comp_lo, std::array<Index3, 3>& comp_hi,
                                Index3& lo, Index3& hi) const {
  // The influence box of each component: beyond ceil(max |v_c| / slack) links along an axis no
  // bound of component c reaches 0 (each component is its own problem, so a press along y
  // with little drag sweeps the x and z components over a much smaller box). The union of the
  // three is where anything can move.
  Index3 anchor_lo{}, anchor_hi{};
  std::array<double, 3> largest{};
  for (int a = 0; a < 3; ++a) {
    anchor_lo[a] = dims_[a];
    anchor_hi[a] = 0;
    lo[a] = dims_[a] - 1;
    hi[a] = 1;
  }
  for (const auto& anchor : held_)
    for (int a = 0; a < 3; ++a) {
      anchor_lo[a] = std::min(anchor_lo[a], anchor.element[a]);
      anchor_hi[a] = std::max(anchor_hi[a], anchor.element[a] + 1);
      largest[a] = std::max(largest[a], std::abs(component(anchor.displacement, a)));
    }
  for (int c = 0; c < 3; ++c)
    for (int a = 0; a < 3; ++a) {
      const double slack = std::min(link_max_[c][a], -link_min_[c][a]);
      const auto reach = static_cast<std::int64_t>(std::ceil(largest[c] / slack));
      comp_lo[c][a] = std::max<std::int64_t>(1, anchor_lo[a] - reach);
      comp_hi[c][a] = std::min<std::int64_t>(dims_[a] - 1, anchor_hi[a] + reach);
      lo[a] = std::min(lo[a], comp_lo[c][a]);
      hi[a] = std::max(hi[a], comp_hi[c][a]);
    }
}

void ChainMail::propagate_component(int c, const Index3& clo, const Index3& chi) {
  const std::int64_t nx = chi[0] - clo[0];
  double* upper = upper_.data();
  double* lower = lower_.data();
  for (std::int64_t k = clo[2]; k < chi[2]; ++k)
    for (std::int64_t j = clo[1]; j < chi[1]; ++j) {
      const auto row = index(clo[0], j, k);
      std::fill(upper + row, upper + row + nx, 0.0);
      std::fill(lower + row, lower + row + nx, 0.0);
    }
  for (const auto& anchor : held_) {
    const auto n = index(anchor.element[0], anchor.element[1], anchor.element[2]);
    upper[n] = lower[n] = component(anchor.displacement, c);
  }
  sweep_rows(c, clo, chi);
  sweep_columns_and_slices(c, clo, chi);
  // The solution nearest rest: lower where it is above 0, upper where it is below (never both
  // once the anchors are compatible). Outside this component's box it is 0 (reset() left it).
  double* d = disp_[c].data();
  for (std::int64_t k = clo[2]; k < chi[2]; ++k)
    for (std::int64_t j = clo[1]; j < chi[1]; ++j) {
      const auto row = index(0, j, k);
      for (std::int64_t i = clo[0]; i < chi[0]; ++i)
        d[row + i] = lower[row + i] > 0.0 ? lower[row + i] : upper[row + i];
    }
  for (const auto& anchor : held_)
    d[index(anchor.element[0], anchor.element[1], anchor.element[2])] =
        component(anchor.displacement, c);
}

void ChainMail::sweep_rows(int c, const Index3& clo, const Index3& chi) {
  // Axis 0: along each row, a dependency chain.
  const double up0 = link_max_[c][0], down0 = -link_min_[c][0];
  for (std::int64_t k = clo[2]; k < chi[2]; ++k)
    for (std::int64_t j = clo[1]; j < chi[1]; ++j) {
      double* u = upper_.data() + index(0, j, k);
      double* l = lower_.data() + index(0, j, k);
      for (std::int64_t i = clo[0] + 1; i < chi[0]; ++i) {
        u[i] = std::min(u[i], u[i - 1] + up0);
        l[i] = std::max(l[i], l[i - 1] - down0);
      }
      for (std::int64_t i = chi[0] - 2; i >= clo[0]; --i) {
        u[i] = std::min(u[i], u[i + 1] + down0);
        l[i] = std::max(l[i], l[i + 1] - up0);
      }
    }
}

void ChainMail::sweep_columns_and_slices(int c, const Index3& clo, const Index3& chi) {
  // Axes 1 and 2: whole rows at a time (independent along i, so they vectorise).
  const std::int64_t nx = chi[0] - clo[0];
  const std::int64_t stride_j = dims_[0], stride_k = dims_[0] * dims_[1];
  double* upper = upper_.data();
  double* lower = lower_.data();
  for (int a = 1; a < 3; ++a) {
    const double up = link_max_[c][a], down = -link_min_[c][a];
    const std::int64_t stride = a == 1 ? stride_j : stride_k;
    const std::int64_t outer_lo = a == 1 ? clo[2] : clo[1], outer_hi = a == 1 ? chi[2] : chi[1];
    for (std::int64_t outer = outer_lo; outer < outer_hi; ++outer) {
      const auto base = a == 1 ? index(clo[0], 0, outer) : index(clo[0], outer, 0);
      for (std::int64_t s = clo[a] + 1; s < chi[a]; ++s) {
        double* u = upper + base + s * stride;
        double* l = lower + base + s * stride;
        const double* up_prev = u - stride;
        const double* low_prev = l - stride;
        for (std::int64_t i = 0; i < nx; ++i) {
          u[i] = std::min(u[i], up_prev[i] + up);
          l[i] = std::max(l[i], low_prev[i] - down);
        }
      }
      for (std::int64_t s = chi[a] - 2; s >= clo[a]; --s) {
        double* u = upper + base + s * stride;
        double* l = lower + base + s * stride;
        const double* up_next = u + stride;
        const double* low_next = l + stride;
        for (std::int64_t i = 0; i < nx; ++i) {
          u[i] = std::min(u[i], up_next[i] + down);
          l[i] = std::max(l[i], low_next[i] - up);
        }
      }
    }
  }
}

std::int64_t ChainMail::measure_moved(const Index3& lo, const Index3& hi) {
  // Count what moved, the tight box around it, and each component's own (relax() starts from
  // those).
  // Row by row: the count (a branch-free loop) and each component's first and last nonzero
  // element; the moved box is the union of the components' boxes.
  std::int64_t moved = 0;
  for (int c = 0; c < 3; ++c) {
    support_lo_[c] = hi;
    support_hi_[c] = lo;
  }
  for (std::int64_t k = lo[2]; k < hi[2]; ++k)
    for (std::int64_t j = lo[1]; j < hi[1]; ++j) {
      const auto row = index(0, j, k);
      const double* d0 = disp_[0].data() + row;
      const double* d1 = disp_[1].data() + row;
      const double* d2 = disp_[2].data() + row;
      std::int64_t in_row = 0;
      for (std::int64_t i = lo[0]; i < hi[0]; ++i)
        in_row += (d0[i] != 0.0) | (d1[i] != 0.0) | (d2[i] != 0.0);
      if (in_row == 0) continue;
      moved += in_row;
      for (int c = 0; c < 3; ++c) {
        const double* d = disp_[c].data() + row;
        std::int64_t first = lo[0];
        while (first < hi[0] && d[first] == 0.0) ++first;
        if (first == hi[0]) continue;
        std::int64_t last = hi[0] - 1;
        while (d[last] == 0.0) --last;
        Index3& slo = support_lo_[c];
        Index3& shi = support_hi_[c];
        slo = {std::min(slo[0], first), std::min(slo[1], j), std::min(slo[2], k)};
        shi = {std::max(shi[0], last + 1), std::max(shi[1], j + 1), std::max(shi[2], k + 1)};
      }
    }
  Index3 moved_lo = hi, moved_hi = lo;
  for (int c = 0; c < 3; ++c)
    for (int a = 0; a < 3; ++a)
      if (support_lo_[c][0] < support_hi_[c][0]) {
        moved_lo[a] = std::min(moved_lo[a], support_lo_[c][a]);
        moved_hi[a] = std::max(moved_hi[a], support_hi_[c][a]);
      }
  if (moved == 0) return 0;
  active_lo_ = moved_lo;
  active_hi_ = moved_hi;
  return moved;
}

void ChainMail::relax() {
  if (params_.relax_iterations == 0 || params_.relax_rate == 0.0) return;
  if (active_lo_[0] >= active_hi_[0]) return;
  // Relax the moved box grown by one element (clipped to the interior); nothing outside moves.
  Index3 lo{}, hi{};
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::max<std::int64_t>(1, active_lo_[a] - 1);
    hi[a] = std::min<std::int64_t>(dims_[a] - 1, active_hi_[a] + 1);
  }
  const std::int64_t sj = dims_[0], sk = dims_[0] * dims_[1];
  const double rate = params_.relax_rate;
  constexpr double kSixth = 1.0 / 6.0;
  Index3 done_lo = hi, done_hi = lo;  // the union of what each component may have moved
  for (int c = 0; c < 3; ++c) {
    double* d = disp_[c].data();
    const double m0 = link_min_[c][0], m1 = link_min_[c][1], m2 = link_min_[c][2];
    const double x0 = link_max_[c][0], x1 = link_max_[c][1], x2 = link_max_[c][2];
    auto relax_one = [&](std::int64_t n) {
      const double xm = d[n - 1], xp = d[n + 1], ym = d[n - sj], yp = d[n + sj];
      const double zm = d[n - sk], zp = d[n + sk];
      const double mean = (xm + xp + ym + yp + zm + zp) * kSixth;
      const double wanted = d[n] + rate * (mean - d[n]);
      const double low = std::max(std::max(std::max(xm + m0, xp - x0), std::max(ym + m1, yp - x1)),
                                  std::max(zm + m2, zp - x2));
      const double high = std::min(std::min(std::min(xm + x0, xp - m0), std::min(ym + x1, yp - m1)),
                                   std::min(zm + x2, zp - m2));
      d[n] = std::min(std::max(wanted, low), high);
    };
    // This component's nonzero box. An element that is 0 with six neighbours at 0 stays exactly
    // 0 (wanted 0, low < 0 < high), so a pass needs only that box grown by one element; the
    // box grows by one per pass until it fills the relaxed box. Same values as relaxing the
    // whole box, a fraction of the work for a component that moved less far.
    Index3 slo = support_lo_[c], shi = support_hi_[c];
    if (slo[0] >= shi[0] || slo[1] >= shi[1] || slo[2] >= shi[2]) continue;  // all 0: stays so
    // Red-black order: the elements of one colour have neighbours of the other colour only,
    // so they update independently (no dependency chain along a row) and each still clamps
    // against its neighbours' current values. The colour that goes first alternates.
    for (int sweep = 0; sweep < params_.relax_iterations; ++sweep)
      for (int pass = 0; pass < 2; ++pass) {
        for (int a = 0; a < 3; ++a) {
          slo[a] = std::max(lo[a], slo[a] - 1);
          shi[a] = std::min(hi[a], shi[a] + 1);
        }
        const std::int64_t colour = (sweep + pass + origin_parity_) % 2;
        for (std::int64_t k = slo[2]; k < shi[2]; ++k)
          for (std::int64_t j = slo[1]; j < shi[1]; ++j) {
            const std::int64_t first = slo[0] + ((slo[0] + j + k + colour) & 1);
            const auto row = index(0, j, k);
            for (std::int64_t i = first; i < shi[0]; i += 2) relax_one(row + i);
          }
        // The held anchors do not move: put back the ones this pass relaxed (their neighbours,
        // of the other colour, were not read this pass, so this equals skipping them).
        for (const auto& anchor : held_) {
          const auto n = index(anchor.element[0], anchor.element[1], anchor.element[2]);
          d[n] = component(anchor.displacement, c);
        }
      }
    for (int a = 0; a < 3; ++a) {
      done_lo[a] = std::min(done_lo[a], slo[a]);
      done_hi[a] = std::max(done_hi[a], shi[a]);
    }
  }
  // Every nonzero displacement lies in the union (the moved box is inside it).
  for (int a = 0; a < 3; ++a) {
    active_lo_[a] = std::min(active_lo_[a], done_lo[a]);
    active_hi_[a] = std::max(active_hi_[a], done_hi[a]);
  }
}

double ChainMail::max_violation() const {
  double worst = 0.0;
  const std::int64_t strides[3] = {1, dims_[0], dims_[0] * dims_[1]};
  for (int a = 0; a < 3; ++a)
    for (std::int64_t k = 0; k < dims_[2] - (a == 2); ++k)
      for (std::int64_t j = 0; j < dims_[1] - (a == 1); ++j)
        for (std::int64_t i = 0; i < dims_[0] - (a == 0); ++i) {
          const auto e = index(i, j, k);
          for (int c = 0; c < 3; ++c) {
            const double diff = disp_[c][e + strides[a]] - disp_[c][e];
            worst = std::max({worst, link_min_[c][a] - diff, diff - link_max_[c][a]});
          }
        }
  return worst;
}

}  // namespace palp
