// Compact detached islands removed from the bone mask (see bone_islands.hpp).
#include "prep/bone/bone_islands.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "prep/segment/components.hpp"

namespace palp::segmentation {
namespace {

// The eigenvalues of a symmetric 3x3 matrix (xx, yy, zz, xy, xz, yz), largest first (closed form).
std::array<double, 3> eigenvalues(const std::array<double, 6>& c) {
  const double p1 = c[3] * c[3] + c[4] * c[4] + c[5] * c[5];
  const double q = (c[0] + c[1] + c[2]) / 3.0;
  if (p1 <= 0.0) {
    std::array<double, 3> e{c[0], c[1], c[2]};
    std::sort(e.begin(), e.end(), [](double a, double b) { return a > b; });
    return e;
  }
  const double p2 =
      (c[0] - q) * (c[0] - q) + (c[1] - q) * (c[1] - q) + (c[2] - q) * (c[2] - q) + 2.0 * p1;
  const double p = std::sqrt(p2 / 6.0);
  const double b0 = (c[0] - q) / p, b1 = (c[1] - q) / p, b2 = (c[2] - q) / p;
  const double b3 = c[3] / p, b4 = c[4] / p, b5 = c[5] / p;
  const double det = b0 * (b1 * b2 - b5 * b5) - b3 * (b3 * b2 - b5 * b4) + b4 * (b3 * b5 - b1 * b4);
  const double r = std::clamp(det / 2.0, -1.0, 1.0);
  const double phi = std::acos(r) / 3.0;
  const double pi = std::acos(-1.0);
  const double e1 = q + 2.0 * p * std::cos(phi);
  const double e3 = q + 2.0 * p * std::cos(phi + 2.0 * pi / 3.0);
  return {e1, 3.0 * q - e1 - e3, e3};
}

}  // namespace

// In a box around the island, the squared distance to the island, one axis after the other (min
// over offsets within the reach of value + offset^2: exact for distances up to the reach),
// compared with the bone there.
bool near_other_bone(const Mask& bone, const RunTable& runs, const RunLabels& labels,
                     std::int64_t c, const std::array<std::int64_t, 3>& lo,
                     const std::array<std::int64_t, 3>& hi, double reach_mm) {
  const Grid& g = bone.grid;
  std::array<std::int64_t, 3> b0{}, b1{}, size{}, reach{};
  for (int a = 0; a < 3; ++a) {
    reach[a] = static_cast<std::int64_t>(std::floor(reach_mm / g.spacing[a]));
    b0[a] = std::max<std::int64_t>(0, lo[a] - reach[a]);
    b1[a] = std::min<std::int64_t>(g.dims[a], hi[a] + 1 + reach[a]);
    size[a] = b1[a] - b0[a];
  }
  const auto local = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return static_cast<std::size_t>((i - b0[0]) + size[0] * ((j - b0[1]) + size[1] * (k - b0[2])));
  };
  constexpr double kFar = 1e30;
  std::vector<double> d2(static_cast<std::size_t>(size[0] * size[1] * size[2]), kFar);
  std::vector<std::uint8_t> own(d2.size(), 0);
  for (std::int64_t k = lo[2]; k <= hi[2]; ++k)
    for (std::int64_t j = lo[1]; j <= hi[1]; ++j) {
      const std::int64_t row = j + g.dims[1] * k;
      for (std::int64_t r = runs.row_start[row]; r < runs.row_start[row + 1]; ++r)
        if (labels.of_run[r] == c)
          for (std::int64_t i = runs.runs[r].begin; i < runs.runs[r].end; ++i)
            own[local(i, j, k)] = 1, d2[local(i, j, k)] = 0.0;
    }
  std::vector<double> line;
  for (int a = 0; a < 3; ++a) {
    const std::int64_t stride = a == 0 ? 1 : (a == 1 ? size[0] : size[0] * size[1]);
    const std::int64_t n = size[a];
    line.resize(static_cast<std::size_t>(n));
    for (std::int64_t k = 0; k < (a == 2 ? 1 : size[2]); ++k)
      for (std::int64_t j = 0; j < (a == 1 ? 1 : size[1]); ++j)
        for (std::int64_t i = 0; i < (a == 0 ? 1 : size[0]); ++i) {
          const std::int64_t base = i + size[0] * (j + size[1] * k);
          for (std::int64_t t = 0; t < n; ++t) {
            double best = kFar;
            for (std::int64_t u = std::max<std::int64_t>(0, t - reach[a]);
                 u <= std::min<std::int64_t>(n - 1, t + reach[a]); ++u) {
              const double step = static_cast<double>(t - u) * g.spacing[a];
              best = std::min(best, d2[static_cast<std::size_t>(base + u * stride)] + step * step);
            }
            line[static_cast<std::size_t>(t)] = best;
          }
          for (std::int64_t t = 0; t < n; ++t)
            d2[static_cast<std::size_t>(base + t * stride)] = line[static_cast<std::size_t>(t)];
        }
  }
  for (std::int64_t k = b0[2]; k < b1[2]; ++k)
    for (std::int64_t j = b0[1]; j < b1[1]; ++j)
      for (std::int64_t i = b0[0]; i < b1[0]; ++i) {
        const std::size_t n = local(i, j, k);
        if (!own[n] && d2[n] <= reach_mm * reach_mm && bone.data[g.linear(i, j, k)]) return true;
      }
  return false;
}

std::vector<IslandShape> island_shapes(const Grid& g, const RunTable& runs,
                                       const RunLabels& labels) {
  // Per island: voxel count, first and second moments of the voxel centres (mm).
  struct Moments {
    double n = 0.0;
    std::array<double, 3> sum{};
    std::array<double, 6> sum2{};  // xx, yy, zz, xy, xz, yz
  };
  const std::size_t count = labels.voxels.size();
  std::vector<Moments> m(count);
  std::vector<IslandShape> shapes(count);
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  // Serial: one pass over the runs, sums per island (a run adds its voxels in closed form along i).
  for (std::int64_t row = 0; row < ny * nz; ++row) {
    const std::int64_t j = row % ny, k = row / ny;
    const double y = static_cast<double>(j) * g.spacing[1];
    const double z = static_cast<double>(k) * g.spacing[2];
    const bool border_row = j == 0 || j == ny - 1 || k == 0 || k == nz - 1;
    for (std::int64_t r = runs.row_start[row]; r < runs.row_start[row + 1]; ++r) {
      const auto c = static_cast<std::size_t>(labels.of_run[r]);
      Moments& s = m[c];
      IslandShape& shape = shapes[c];
      const Run run = runs.runs[r];
      if (border_row || run.begin == 0 || run.end == nx) shape.border = true;
      const double len = static_cast<double>(run.end - run.begin);
      const double a = static_cast<double>(run.begin), b = static_cast<double>(run.end - 1);
      const double sx = (a + b) * len / 2.0 * g.spacing[0];
      // Sum of i^2 over [a, b]: b(b+1)(2b+1)/6 - (a-1)a(2a-1)/6.
      const double sxx = (b * (b + 1) * (2 * b + 1) - (a - 1) * a * (2 * a - 1)) / 6.0 *
                         g.spacing[0] * g.spacing[0];
      s.n += len;
      s.sum[0] += sx, s.sum[1] += y * len, s.sum[2] += z * len;
      s.sum2[0] += sxx, s.sum2[1] += y * y * len, s.sum2[2] += z * z * len;
      s.sum2[3] += sx * y, s.sum2[4] += sx * z, s.sum2[5] += y * z * len;
    }
  }
  // The spread of the voxels' centres plus each voxel's own (a box of side h: h^2 / 12), so that
  // an island one slice thick is as thick as its slice, and a cube of side L is L long.
  const auto own = [&](int axis) { return g.spacing[axis] * g.spacing[axis] / 12.0; };
  for (std::size_t c = 0; c < count; ++c) {
    const Moments& s = m[c];
    if (s.n <= 0.0) continue;
    const double mx = s.sum[0] / s.n, my = s.sum[1] / s.n, mz = s.sum[2] / s.n;
    const std::array<double, 6> cov{
        s.sum2[0] / s.n - mx * mx + own(0), s.sum2[1] / s.n - my * my + own(1),
        s.sum2[2] / s.n - mz * mz + own(2), s.sum2[3] / s.n - mx * my,
        s.sum2[4] / s.n - mx * mz,          s.sum2[5] / s.n - my * mz};
    const std::array<double, 3> e = eigenvalues(cov);
    for (int a = 0; a < 3; ++a) shapes[c].sd[a] = std::sqrt(std::max(e[a], 0.0));
  }
  return shapes;
}

void remove_compact_islands(const SegmentationParams& params, Mask& bone) {
  const double max_length = params.bone_calculus_max_length_mm;
  if (max_length <= 0.0) return;
  const Grid& g = bone.grid;
  const RunTable runs = extract_runs(bone, false);
  const RunLabels labels = label_runs(g, runs);
  const std::size_t count = labels.voxels.size();
  if (count < 2) return;
  const std::vector<IslandShape> shapes = island_shapes(g, runs, labels);
  const std::vector<ComponentBox> boxes = component_boxes(g, runs, labels);
  const auto largest = static_cast<std::int64_t>(
      std::max_element(labels.voxels.begin(), labels.voxels.end()) - labels.voxels.begin());
  std::vector<std::uint8_t> keep(count, 1);
  // A gap of up to kBoneJointGapMm of non-bone between two voxels: centres that far plus a voxel.
  const double reach = kBoneJointGapMm + g.max_spacing();
  for (std::size_t c = 0; c < count; ++c) {
    const IslandShape& s = shapes[c];
    if (static_cast<std::int64_t>(c) == largest || s.border) continue;
    const double length = 2.0 * std::sqrt(3.0) * s.sd[0];
    const bool compact = s.sd[0] < kBoneIslandElongation * s.sd[2];
    if (length >= max_length || !compact) continue;
    if (near_other_bone(bone, runs, labels, static_cast<std::int64_t>(c), boxes[c].lo, boxes[c].hi,
                        reach))
      continue;
    keep[c] = 0;
  }
  rewrite_runs(
      g, runs, labels, [&](std::int64_t c) { return keep[static_cast<std::size_t>(c)]; }, bone);
}

}  // namespace palp::segmentation
