// The anterior column slice by slice: the body block near the midline, then its centre line
// smoothed over the discs (spine_levels.hpp).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>

#include "anatomy/spine_internal.hpp"

namespace palp::anatomy {
namespace {

// The bone run along x through (x, y, z): its first and last x, or nothing.
std::optional<std::pair<std::int64_t, std::int64_t>> run_through(const PatientMask& bone,
                                                                 std::int64_t x, std::int64_t y,
                                                                 std::int64_t z) {
  if (!bone.at(x, y, z)) return std::nullopt;
  std::int64_t a = x, b = x;
  while (bone.at(a - 1, y, z)) --a;
  while (bone.at(b + 1, y, z)) ++b;
  return std::pair{a, b};
}

struct Block {
  double x = 0.0, y = 0.0, y_front = 0.0, y_back = 0.0, area = 0.0;
};

// The block of consecutive rows (one missing row bridged) whose run through the midline is at
// least a vertebral body wide, in the posterior 70 % of the body; the largest by area.
std::optional<Block> body_block(const PatientMask& bone, const SliceBody& body, double x_mid,
                                std::int64_t z) {
  const double depth = body.y_back - body.y_front;
  const auto y0 =
      std::max<std::int64_t>(0, static_cast<std::int64_t>(std::ceil(body.cy - 0.2 * depth)));
  const auto y1 = std::min<std::int64_t>(bone.dims[1] - 1, static_cast<std::int64_t>(body.y_back));
  const double min_voxels = kMinBodyWidthMm / bone.spacing[0];
  const auto xr = static_cast<std::int64_t>(std::lround(x_mid));
  std::optional<Block> best;
  Block current;
  double sx = 0.0, sy = 0.0;
  std::int64_t last = -10;
  const auto close = [&] {
    if (current.area <= 0.0) return;
    current.x = sx / current.area, current.y = sy / current.area;
    if (!best || current.area > best->area) best = current;
    current = Block{}, sx = sy = 0.0;
  };
  for (std::int64_t y = y0; y <= y1; ++y) {
    double width = 0.0, centre = 0.0;
    for (std::int64_t dx = -1; dx <= 1; ++dx) {
      const auto run = run_through(bone, xr + dx, y, z);
      if (run && static_cast<double>(run->second - run->first + 1) > width) {
        width = static_cast<double>(run->second - run->first + 1);
        centre = 0.5 * static_cast<double>(run->first + run->second);
      }
    }
    if (width < min_voxels) continue;
    if (y - last > 2) close();
    if (current.area <= 0.0) current.y_front = static_cast<double>(y);
    current.y_back = static_cast<double>(y);
    current.area += width, sx += width * centre, sy += width * static_cast<double>(y);
    last = y;
  }
  close();
  return best;
}

// The median of the found values within `half` slices of each slice (NaN where none).
std::vector<double> windowed_median(const std::vector<double>& values, std::int64_t half) {
  const auto n = static_cast<std::int64_t>(values.size());
  std::vector<double> out(values.size(), std::nan(""));
  std::vector<double> window;
  for (std::int64_t z = 0; z < n; ++z) {
    window.clear();
    for (std::int64_t w = std::max<std::int64_t>(0, z - half); w <= std::min(n - 1, z + half); ++w)
      if (std::isfinite(values[static_cast<std::size_t>(w)]))
        window.push_back(values[static_cast<std::size_t>(w)]);
    if (window.empty()) continue;
    std::nth_element(window.begin(),
                     window.begin() + static_cast<std::ptrdiff_t>(window.size() / 2), window.end());
    out[static_cast<std::size_t>(z)] = window[window.size() / 2];
  }
  return out;
}

// NaNs between finite values filled linearly; before the first and after the last, the nearest.
void fill_linear(std::vector<double>& v) {
  const auto n = static_cast<std::int64_t>(v.size());
  std::int64_t prev = -1;
  for (std::int64_t z = 0; z < n; ++z) {
    if (!std::isfinite(v[static_cast<std::size_t>(z)])) continue;
    if (prev < 0) {
      for (std::int64_t w = 0; w < z; ++w)
        v[static_cast<std::size_t>(w)] = v[static_cast<std::size_t>(z)];
    } else {
      const double a = v[static_cast<std::size_t>(prev)], b = v[static_cast<std::size_t>(z)];
      for (std::int64_t w = prev + 1; w < z; ++w)
        v[static_cast<std::size_t>(w)] =
            a + (b - a) * static_cast<double>(w - prev) / static_cast<double>(z - prev);
    }
    prev = z;
  }
  if (prev >= 0)
    for (std::int64_t w = prev + 1; w < n; ++w)
      v[static_cast<std::size_t>(w)] = v[static_cast<std::size_t>(prev)];
}

// The longest chain of found slices whose gaps are no longer than a disc and a half (25 mm).
std::pair<std::int64_t, std::int64_t> column_range(const std::vector<double>& found_y,
                                                   double slice_mm) {
  const auto n = static_cast<std::int64_t>(found_y.size());
  const auto max_gap = static_cast<std::int64_t>(std::floor(25.0 / slice_mm)) + 1;
  std::pair<std::int64_t, std::int64_t> best{-1, -2}, current{-1, -2};
  std::int64_t last = -1000000;
  for (std::int64_t z = 0; z < n; ++z) {
    if (!std::isfinite(found_y[static_cast<std::size_t>(z)])) continue;
    if (z - last > max_gap) current = {z, z};
    current.second = z;
    last = z;
    if (current.second - current.first > best.second - best.first) best = current;
  }
  return best;
}

}  // namespace

std::vector<ColumnSlice> find_column(const PatientMask& bone,
                                     const std::vector<SliceBody>& bodies) {
  const auto nz = bone.dims[2];
  const auto half = std::max<std::int64_t>(1, std::lround(12.0 / bone.spacing[2]));
  std::vector<double> x_mid(static_cast<std::size_t>(nz), std::nan(""));
  for (std::int64_t z = 0; z < nz; ++z)
    if (bodies[static_cast<std::size_t>(z)].voxels)
      x_mid[static_cast<std::size_t>(z)] = bodies[static_cast<std::size_t>(z)].cx;
  fill_linear(x_mid);
  std::vector<double> fx, fy, fd;
  for (int pass = 0; pass < 2; ++pass) {
    fx.assign(static_cast<std::size_t>(nz), std::nan(""));
    fy = fx, fd = fx;
    for (std::int64_t z = 0; z < nz; ++z) {
      const SliceBody& body = bodies[static_cast<std::size_t>(z)];
      if (!body.voxels) continue;
      const auto block = body_block(bone, body, x_mid[static_cast<std::size_t>(z)], z);
      if (!block) continue;
      fx[static_cast<std::size_t>(z)] = block->x, fy[static_cast<std::size_t>(z)] = block->y;
      fd[static_cast<std::size_t>(z)] = block->y_back - block->y_front + 1.0;
    }
    std::vector<double> sx = windowed_median(fx, half);
    fill_linear(sx);
    if (std::any_of(sx.begin(), sx.end(), [](double v) { return std::isfinite(v); })) x_mid = sx;
  }
  std::vector<ColumnSlice> column(static_cast<std::size_t>(nz));
  const auto [lo, hi] = column_range(fy, bone.spacing[2]);
  if (hi < lo) return column;
  std::vector<double> sy = windowed_median(fy, half), sd = windowed_median(fd, half);
  fill_linear(sy), fill_linear(sd);
  for (std::int64_t z = 0; z < nz; ++z) {
    ColumnSlice& c = column[static_cast<std::size_t>(z)];
    c.found = std::isfinite(fy[static_cast<std::size_t>(z)]);
    c.on_column = z >= lo && z <= hi;
    c.x = x_mid[static_cast<std::size_t>(z)], c.y = sy[static_cast<std::size_t>(z)];
    c.depth = sd[static_cast<std::size_t>(z)];
  }
  return column;
}

}  // namespace palp::anatomy
