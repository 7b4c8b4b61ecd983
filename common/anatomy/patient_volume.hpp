// Volumes seen in the patient's own axes, for finding landmarks independently of how the scan
// was stored: a mask re-stored with index x toward the patient's left, y posterior and z superior
// (LPS), and the skin's signed distance sampled at world points.
//
// prep resamples oblique scans onto the nearest axis-aligned frame, so a prep directory's grids
// are signed permutations of LPS and re-storing is exact (no interpolation).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "base/vec.hpp"
#include "base/volume.hpp"

namespace palp::anatomy {

// A mask in the patient's axis order. Index (x, y, z) grows toward left, posterior, superior.
struct PatientMask {
  Index3 dims{0, 0, 0};
  Vec3 spacing{1.0, 1.0, 1.0};  // mm per index step along x, y, z
  std::vector<std::uint8_t> data;
  Grid source;                          // the grid the mask was stored on
  std::array<int, 3> axis_of{0, 1, 2};  // patient axis a is source index axis axis_of[a]
  std::array<int, 3> sign{1, 1, 1};     // +1: that source index grows toward L, P or S

  bool contains(std::int64_t x, std::int64_t y, std::int64_t z) const {
    return x >= 0 && y >= 0 && z >= 0 && x < dims[0] && y < dims[1] && z < dims[2];
  }
  std::size_t linear(std::int64_t x, std::int64_t y, std::int64_t z) const {
    return static_cast<std::size_t>(x + dims[0] * (y + dims[1] * z));
  }
  // 0 outside the grid.
  bool at(std::int64_t x, std::int64_t y, std::int64_t z) const {
    return contains(x, y, z) && data[linear(x, y, z)] != 0;
  }
  // The LPS world point (mm) of a (fractional) patient index.
  Vec3d world(const Vec3d& index) const;
  // The (fractional) patient index of an LPS world point.
  Vec3d index_of(const Vec3d& world_mm) const;
};

// Re-stores `mask` in the patient's axis order (its grid's direction, nearest axes).
PatientMask to_patient_order(const Mask& mask);
// The same re-storing for another mask on the same grid (one that is not: InputError); its
// values as they are with `keep_values` (a label volume), else 0/1.
PatientMask to_patient_order_like(const Mask& mask, const PatientMask& like,
                                  bool keep_values = false);

// The body in each axial slice (patient index units): its centroid and its extent from the
// anterior to the posterior skin. `voxels` 0: no body in that slice.
struct SliceBody {
  std::int64_t voxels = 0;
  double cx = 0.0, cy = 0.0;
  double y_front = 0.0, y_back = 0.0;
};
std::vector<SliceBody> slice_bodies(const PatientMask& body);

// A 6-connected piece of a mask: its voxels (linear patient indices), centroid and extent.
struct Piece {
  std::vector<std::size_t> voxels;
  Vec3d centroid{};
  Index3 lo{0, 0, 0}, hi{-1, -1, -1};
};
// The pieces of the voxels of `mask` for which keep(x, y, z) holds; pieces under min_voxels are
// left out.
template <class Keep>
std::vector<Piece> pieces_of(const PatientMask& mask, Keep keep, std::size_t min_voxels);
// The index (x, y, z) of a linear patient index.
inline Index3 index3(const PatientMask& m, std::size_t n) {
  const auto i = static_cast<std::int64_t>(n);
  return {i % m.dims[0], (i / m.dims[0]) % m.dims[1], i / (m.dims[0] * m.dims[1])};
}

// The skin's signed distance (mm, positive inside: prep's d_surf) at world points.
class SkinMap {
 public:
  SkinMap() = default;
  explicit SkinMap(DistanceMap d_surf) : map_(std::move(d_surf)) {}
  bool empty() const { return map_.data.empty(); }
  // Trilinear at an LPS world point; the clamped edge value outside the grid.
  double distance(const Vec3d& world_mm) const;
  // The outward unit normal (minus the distance's gradient), or nothing where it is flat.
  std::optional<Vec3d> outward_normal(const Vec3d& world_mm) const;
  // The skin point met going from `start` along the unit `direction` within `max_mm`: where the
  // distance changes sign, refined by bisection to 0.01 mm; nothing when it never does.
  std::optional<Vec3d> project(const Vec3d& start, const Vec3d& direction, double max_mm) const;

 private:
  DistanceMap map_;
};

template <class Keep>
std::vector<Piece> pieces_of(const PatientMask& mask, Keep keep, std::size_t min_voxels) {
  std::vector<Piece> out;
  std::vector<std::uint8_t> seen(mask.data.size(), 0);
  std::vector<std::size_t> stack;
  const std::int64_t step[3] = {1, mask.dims[0], mask.dims[0] * mask.dims[1]};
  for (std::size_t start = 0; start < mask.data.size(); ++start) {
    if (seen[start] || !mask.data[start]) continue;
    const Index3 s = index3(mask, start);
    if (!keep(s[0], s[1], s[2])) continue;
    Piece piece;
    stack.assign(1, start);
    seen[start] = 1;
    while (!stack.empty()) {
      const std::size_t n = stack.back();
      stack.pop_back();
      piece.voxels.push_back(n);
      const Index3 p = index3(mask, n);
      for (int a = 0; a < 3; ++a)
        for (int d = -1; d <= 1; d += 2) {
          Index3 q = p;
          q[a] += d;
          if (!mask.contains(q[0], q[1], q[2])) continue;
          const auto m = static_cast<std::size_t>(static_cast<std::int64_t>(n) + d * step[a]);
          if (seen[m] || !mask.data[m] || !keep(q[0], q[1], q[2])) continue;
          seen[m] = 1;
          stack.push_back(m);
        }
    }
    if (piece.voxels.size() < min_voxels) continue;
    Vec3d sum{};
    piece.lo = {mask.dims[0], mask.dims[1], mask.dims[2]};
    for (std::size_t n : piece.voxels) {
      const Index3 p = index3(mask, n);
      sum += Vec3d{static_cast<double>(p[0]), static_cast<double>(p[1]), static_cast<double>(p[2])};
      for (int a = 0; a < 3; ++a)
        piece.lo[a] = std::min(piece.lo[a], p[a]), piece.hi[a] = std::max(piece.hi[a], p[a]);
    }
    piece.centroid = sum * (1.0 / static_cast<double>(piece.voxels.size()));
    out.push_back(std::move(piece));
  }
  return out;
}

}  // namespace palp::anatomy
