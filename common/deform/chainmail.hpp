// 3D ChainMail (S. Gibson, 1997) with elastic relaxation, on a box of voxel elements: each
// element is linked to its six face neighbours; a link along axis a between elements e and n
// (n the neighbour at +a) holds when
//   min_stretch * h_a <= (n - e)_a <= max_stretch * h_a      (compression and stretch)
//   |(n - e)_b| <= max_shear * h_a  for the two other axes b  (shear)
// In displacements d (position minus rest) every bound is an interval on one component of
// d_n - d_e, so the three components are independent problems of difference constraints.
//
// Data flow of solve():
//   anchors -> merged per element (mean) -> each held anchor clamped, in input order, into the
//   interval its predecessors and the rest boundary allow (so the held set is always
//   consistent; an incompatible anchor gives way, earlier anchors win) -> propagation: every
//   free element moves the least distance that satisfies its links (ChainMail's minimal move),
//   computed exactly as the fixpoint of Gibson's neighbour-by-neighbour propagation: per
//   component, clamp(0, lower, upper) where lower/upper are the tightest bounds the anchors
//   imply through chains of links (a weighted L1 distance, two min-plus sweeps per axis, linear
//   in the elements of the influence box; order-independent, no queue) -> elastic relaxation:
//   red-black Gauss-Seidel sweeps move each free element part of the way toward the mean of its
//   six neighbours and clamp it into the interval its links allow, so every link still holds
//   after every step -> displacement per element.
// Elements on the box's boundary are held at rest: the deformation stays inside the box.
// Storage is kept across resize() calls; solve() does not allocate once the box and the number
// of anchors have reached their largest size.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "base/vec.hpp"

namespace palp {

// Defaults for soft tissue (skin and fat) at render-volume spacing (1-2 mm voxels): a link may
// stretch or compress by half its rest length and shear by half of it, so a displacement of D
// mm fades to zero within about D / (0.5 h) elements (10 mm at h = 2 mm: ten elements, 20 mm),
// which is the fall-off of a fingertip press seen on skin; four relaxation sweeps at rate 0.5
// round off the kinks the minimal propagation leaves without costing much time.
struct ChainMailParams {
  double min_stretch = 0.5;  // of the rest spacing, in (0, 1]
  double max_stretch = 1.5;  // of the rest spacing, >= 1
  double max_shear = 0.5;    // of the rest spacing, > 0
  int relax_iterations = 4;  // red-black Gauss-Seidel sweeps over the moved box (+1 element)
  double relax_rate = 0.5;   // 0..1: fraction of the way toward the neighbours' mean per sweep
};

struct ChainMailAnchor {
  std::array<std::int64_t, 3> element{};  // box-local index
  Vec3d displacement{};                   // mm, from rest
};

class ChainMail {
 public:
  // UsageError for parameters outside the ranges above.
  explicit ChainMail(ChainMailParams params = {});

  // A box of dims elements at rest spacing h (mm), every element at rest. Keeps the allocation
  // (and its size: every element beyond the box stays at rest) when it shrinks. `origin`: the box's
  // first element in a larger lattice (a region of interest that moves with the tool): the
  // red-black colours of the relaxation follow the parity of origin + local index, so where the box
  // starts does not change the result. UsageError for a non-positive dimension or spacing.
  void resize(std::array<std::int64_t, 3> dims, std::array<double, 3> h,
              std::array<std::int64_t, 3> origin = {});
  // Every element back to rest.
  void reset();
  // Every element back to rest, then the anchors held at their displacement, propagation and
  // relaxation (see the top). Anchors on the boundary or outside the box are ignored (the
  // boundary is held at rest); several anchors on one element hold their mean; an anchor that
  // its predecessors or the boundary make unreachable is clamped to the nearest displacement
  // they allow (held_anchors() says what was held). Returns the number of elements moved by
  // propagation (anchors included).
  std::int64_t solve(std::span<const ChainMailAnchor> anchors);

  Vec3d displacement(std::int64_t i, std::int64_t j, std::int64_t k) const;
  // Component c (0 = x, 1 = y, 2 = z) of every element's displacement, i fastest.
  std::span<const double> displacement_component(int c) const {
    return std::span<const double>(disp_[c]).first(count_);
  }
  // Allocates (and touches) room for `elements` elements now, so that a box of up to that size
  // later costs no allocation or page faults in resize() (the first press of a session).
  void reserve(std::size_t elements);
  // The largest amount (mm) by which any link violates its bounds (0 when all hold).
  double max_violation() const;

  // The anchors the last solve() held, after merging, dropping and clamping.
  std::span<const ChainMailAnchor> held_anchors() const { return held_; }
  // Box-local [lo, hi) outside which every displacement is exactly zero after the last solve()
  // (empty, lo == hi, when nothing moved).
  std::array<std::int64_t, 3> active_lo() const { return active_lo_; }
  std::array<std::int64_t, 3> active_hi() const { return active_hi_; }

  // Along axis a, component c of d_n - d_e (n = e + a) lies in [link_min(c, a), link_max(c, a)].
  double link_min(int component, int axis) const { return link_min_[component][axis]; }
  double link_max(int component, int axis) const { return link_max_[component][axis]; }

  std::array<std::int64_t, 3> dims() const { return dims_; }
  std::array<double, 3> spacing() const { return h_; }
  const ChainMailParams& params() const { return params_; }

 private:
  std::int64_t index(std::int64_t i, std::int64_t j, std::int64_t k) const {
    return i + dims_[0] * (j + dims_[1] * k);
  }
  // The least cost (mm) of a chain of links from element `from` to element `to`, for
  // component c going up (to - from may be that much larger than at rest): weighted L1.
  double chain_slack(int component, const std::array<std::int64_t, 3>& from,
                     const std::array<std::int64_t, 3>& to) const;
  void hold_anchors(std::span<const ChainMailAnchor> anchors);
  using Index3 = std::array<std::int64_t, 3>;
  // The anchors' bounds swept over the box; the solution nearest rest in disp_. Elements moved.
  std::int64_t propagate();
  // Each component's influence box (comp_lo/comp_hi) and their union (lo/hi).
  void influence_boxes(std::array<Index3, 3>& comp_lo, std::array<Index3, 3>& comp_hi, Index3& lo,
                       Index3& hi) const;
  // Component c's bounds seeded at the anchors, swept over its box, the nearest rest written.
  void propagate_component(int c, const Index3& lo, const Index3& hi);
  // Component c's bounds swept forward and back along axis 0, row by row.
  void sweep_rows(int c, const Index3& lo, const Index3& hi);
  // Component c's bounds swept along axes 1 and 2, a whole row at a time.
  void sweep_columns_and_slices(int c, const Index3& lo, const Index3& hi);
  // Counts the elements that moved in [lo, hi); sets support_lo_/hi_ and the active box.
  std::int64_t measure_moved(const Index3& lo, const Index3& hi);
  void relax();
  void zero_box(std::array<std::int64_t, 3> lo, std::array<std::int64_t, 3> hi);

  ChainMailParams params_;
  std::array<std::int64_t, 3> dims_{};
  std::size_t count_ = 0;  // elements in the box (the buffers may hold more: they never shrink)
  std::array<double, 3> h_{1, 1, 1};
  std::int64_t origin_parity_ = 0;  // (origin[0] + origin[1] + origin[2]) & 1
  std::array<std::array<double, 3>, 3> link_min_{}, link_max_{};  // [component][axis]
  std::array<std::vector<double>, 3> disp_;  // displacement from rest per element, per component
  std::vector<double> upper_, lower_;        // propagation scratch, one component at a time
  std::vector<ChainMailAnchor> held_;
  std::vector<std::int64_t> held_weight_;  // anchors merged into each held anchor
  std::array<std::int64_t, 3> active_lo_{}, active_hi_{};
  // Per component, the box outside which it is 0 after propagate() (relax() starts there).
  std::array<std::array<std::int64_t, 3>, 3> support_lo_{}, support_hi_{};
};

}  // namespace palp
