// Marrow between cortices (see bone_enclosure.hpp).
//
// Only voxels within the radius of bone along every axis can be bracketed: a box dilation of the
// bone (three separable passes) picks them, and each is tested line by line, stopping as soon as
// the count is reached or can no longer be.
#include "prep/bone_enclosure.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "prep/components.hpp"

namespace palp::segmentation {
namespace {

struct Line {
  std::array<std::int64_t, 3> step{};  // voxel step along each axis, -1, 0 or 1
  std::int64_t reach = 0;              // steps within the radius
};

// The 13 lines through a voxel of the 3x3x3 neighbourhood (one of each opposite pair).
std::vector<Line> lines_within(const Grid& g, double radius_mm) {
  std::vector<Line> lines;
  for (std::int64_t dz = -1; dz <= 1; ++dz)
    for (std::int64_t dy = -1; dy <= 1; ++dy)
      for (std::int64_t dx = -1; dx <= 1; ++dx) {
        const std::int64_t first = dx != 0 ? dx : dy != 0 ? dy : dz;
        if (first <= 0) continue;
        const double len = std::sqrt(std::pow(static_cast<double>(dx) * g.spacing[0], 2) +
                                     std::pow(static_cast<double>(dy) * g.spacing[1], 2) +
                                     std::pow(static_cast<double>(dz) * g.spacing[2], 2));
        lines.push_back({{dx, dy, dz}, static_cast<std::int64_t>(std::floor(radius_mm / len))});
      }
  return lines;
}

// Box dilation of `in` by r[axis] voxels along each axis (separable running windows).
std::vector<std::uint8_t> box_dilate(const Grid& g, const std::vector<std::uint8_t>& in,
                                     const std::array<std::int64_t, 3>& r) {
  std::vector<std::uint8_t> a = in, b(in.size());
  for (int axis = 0; axis < 3; ++axis) {
    const std::int64_t n = g.dims[axis];
    const std::int64_t stride = axis == 0 ? 1 : axis == 1 ? g.dims[0] : g.dims[0] * g.dims[1];
    const std::int64_t lines = static_cast<std::int64_t>(in.size()) / n;
    parallel_for_chunks(lines, 256, [&](std::int64_t l0, std::int64_t l1) {
      for (std::int64_t l = l0; l < l1; ++l) {
        // The first voxel of line l: l enumerates the other two axes.
        const std::int64_t start =
            axis == 0 ? l * n : axis == 1 ? (l / g.dims[0]) * g.dims[0] * n + l % g.dims[0] : l;
        std::int64_t last = -(1 << 30);  // last set voxel seen going forward
        for (std::int64_t q = 0; q < n; ++q) {
          if (a[static_cast<std::size_t>(start + q * stride)]) last = q;
          b[static_cast<std::size_t>(start + q * stride)] = q - last <= r[axis];
        }
        last = 1 << 30;
        for (std::int64_t q = n - 1; q >= 0; --q) {
          if (a[static_cast<std::size_t>(start + q * stride)]) last = q;
          if (last - q <= r[axis]) b[static_cast<std::size_t>(start + q * stride)] = 1;
        }
      }
    });
    std::swap(a, b);
  }
  return a;
}

}  // namespace

void fill_between_cortices(const PatientAxes& axes, const SegmentationParams& params,
                           const Mask& body, Mask& bone) {
  const int needed = params.bone_enclosure_directions;
  if (needed <= 0) return;
  const Grid& g = bone.grid;
  const std::vector<Line> lines = lines_within(g, params.bone_enclosure_radius_mm);
  std::array<std::int64_t, 3> reach{};
  for (int axis = 0; axis < 3; ++axis)
    reach[axis] = static_cast<std::int64_t>(
        std::floor(params.bone_enclosure_radius_mm / g.spacing[axis]));
  check_allocation(g, 2, "bone enclosure (candidates)");
  const std::vector<std::uint8_t> near = box_dilate(g, bone.data, reach);
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const int slice = axes.slice;
  const auto total = static_cast<int>(lines.size());
  Mask add(g, 0, "bone enclosure");
  parallel_for_chunks(nz, 1, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t k = k0; k < k1; ++k)
      for (std::int64_t j = 0; j < ny; ++j)
        for (std::int64_t i = 0; i < nx; ++i) {
          const std::size_t n = g.linear(i, j, k);
          if (bone.data[n] || !near[n] || !body.data[n]) continue;
          int votes = 0, left = total;
          for (const Line& line : lines) {
            if (votes >= needed || votes + left < needed) break;
            --left;
            bool both = true;
            for (const std::int64_t sign : {1, -1}) {
              bool hit = false;
              for (std::int64_t t = 1; t <= line.reach && !hit; ++t) {
                const std::array<std::int64_t, 3> q = {i + sign * t * line.step[0],
                                                       j + sign * t * line.step[1],
                                                       k + sign * t * line.step[2]};
                if (!g.contains(q[0], q[1], q[2])) {
                  hit = q[slice] < 0 || q[slice] >= g.dims[slice];  // the scan cuts a bone
                  break;
                }
                hit = bone.data[g.linear(q[0], q[1], q[2])] != 0;
              }
              if (!hit) {
                both = false;
                break;
              }
            }
            votes += both;
          }
          if (votes >= needed) add.data[n] = 1;
        }
  });
  for_each_nonzero(add, [&](std::size_t n) { bone.data[n] = 1; });
}

}  // namespace palp::segmentation
