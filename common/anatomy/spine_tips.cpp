// Spinous-process tips (spine_levels.hpp). Along the posterior midline, the most posterior bone
// behind the canal rises to a peak at each spinous process and falls between them (the
// interspinous spaces a needle passes); each vertebra takes the peak nearest to where its own
// process ends: a little below its body's centre (lumbar processes run back and slightly down,
// the lower thoracic ones further down).
//
// The tip is the middle of the process's distal end, not its most posterior point. A horizontal
// (lumbar) process ends in a vertical face: the profile's plateau at the peak, whose middle is
// the tip. A thoracic process slopes down 20-50 degrees, so its end faces back and down: its most
// posterior point is the end's upper corner, and below it the profile comes forward steadily
// along the end (by tan(slope) per mm) down to the interspinous valley under it. The tip is the
// middle of that stretch, from the top of the plateau to where the profile stops coming forward
// (the valley, a turn back, a flat over kLongestFlatMm, or a drop of more than kSteepestEnd per
// mm of height: off the end to the arch).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "anatomy/spine_internal.hpp"

namespace palp::anatomy {
namespace {

// Half the slab's width (mm): a spinous process is 5-10 mm wide at the midline.
constexpr double kSlabHalfWidthMm = 6.0;
// Behind the body's back wall, the canal: posterior arches start at least this far behind (mm).
constexpr double kCanalMm = 5.0;
// Between two processes the profile falls by at least this much (mm).
constexpr double kInterspinousDropMm = 6.0;
// Along a process's end the profile comes forward at most this much per mm down (75 degrees
// from vertical); more is a drop off the end (to the arch, or nothing).
constexpr double kSteepestEnd = 3.7;
// A sloping end comes forward at least a voxel within this height (mm); a longer flat is a
// vertical face (a horizontal process's end, below a one-voxel bump) or the valley's floor.
constexpr double kLongestFlatMm = 5.0;

struct Peak {
  double z = 0.0, y = 0.0;
  bool used = false;
};

// The most posterior slab bone behind the canal per slice (NaN where none).
std::vector<double> posterior_profile(const PatientMask& bone,
                                      const std::vector<ColumnSlice>& column) {
  const auto half = std::max<std::int64_t>(1, std::lround(kSlabHalfWidthMm / bone.spacing[0]));
  std::vector<double> post(column.size(), std::nan(""));
  for (std::size_t z = 0; z < column.size(); ++z) {
    const ColumnSlice& c = column[z];
    if (!c.on_column) continue;
    const auto y0 =
        static_cast<std::int64_t>(std::ceil(c.y + 0.5 * c.depth + kCanalMm / bone.spacing[1]));
    const auto xc = std::lround(c.x);
    for (std::int64_t y = bone.dims[1] - 1; y >= y0 && !std::isfinite(post[z]); --y)
      for (std::int64_t x = xc - half; x <= xc + half; ++x)
        if (bone.at(x, y, static_cast<std::int64_t>(z))) {
          post[z] = static_cast<double>(y);
          break;
        }
  }
  return post;
}

// Peaks: local maxima (plateaus at their middle); two neighbours whose valley between them is
// not `drop` below the lower of the two are one process (the higher stays).
std::vector<Peak> find_peaks(const std::vector<double>& post, double drop) {
  std::vector<Peak> peaks;
  const std::size_t n = post.size();
  const auto value = [&](std::size_t z) { return std::isfinite(post[z]) ? post[z] : -1e30; };
  for (std::size_t z = 0; z < n; ++z) {
    if (!std::isfinite(post[z])) continue;
    std::size_t last = z;
    while (last + 1 < n && post[last + 1] == post[z]) ++last;
    const bool left = z == 0 || value(z - 1) < post[z];
    const bool right = last + 1 == n || value(last + 1) < post[z];
    if (left && right) peaks.push_back({0.5 * static_cast<double>(z + last), post[z], false});
    z = last;
  }
  for (bool merged = true; merged;) {
    merged = false;
    for (std::size_t i = 0; i + 1 < peaks.size() && !merged; ++i) {
      double valley = 1e30;
      for (auto z = static_cast<std::size_t>(peaks[i].z);
           z <= static_cast<std::size_t>(peaks[i + 1].z); ++z)
        valley = std::min(valley, value(z));
      if (valley > std::min(peaks[i].y, peaks[i + 1].y) - drop) {
        peaks.erase(peaks.begin() +
                    static_cast<std::ptrdiff_t>(peaks[i].y >= peaks[i + 1].y ? i + 1 : i));
        merged = true;
      }
    }
  }
  return peaks;
}

// Vertebrae (bottom up) matched to peaks (bottom up) in order, each within its window, the sum
// of the distances from where each process is expected (in vertebral heights) least; a vertebra
// left without one costs kUnmatched.
std::vector<int> match_peaks(const std::vector<VertebraSegment*>& verts,
                             const std::vector<Peak>& peaks) {
  constexpr double kUnmatched = 1.0;
  const std::size_t nv = verts.size(), np = peaks.size();
  std::vector<std::vector<double>> cost(nv + 1, std::vector<double>(np + 1, 1e30));
  std::vector<std::vector<int>> how(nv + 1,
                                    std::vector<int>(np + 1, 0));  // 0 skip v, 1 skip p, 2 match
  for (std::size_t j = 0; j <= np; ++j) cost[0][j] = 0.0;
  for (std::size_t i = 1; i <= nv; ++i) {
    const VertebraSegment& v = *verts[i - 1];
    const double h = std::max(v.z_hi - v.z_lo, 1.0), expected = v.centre.z - 0.35 * h;
    for (std::size_t j = 0; j <= np; ++j) {
      cost[i][j] = cost[i - 1][j] + kUnmatched, how[i][j] = 0;
      if (j > 0 && cost[i][j - 1] < cost[i][j]) cost[i][j] = cost[i][j - 1], how[i][j] = 1;
      if (j == 0) continue;
      const double z = peaks[j - 1].z;
      if (z < v.centre.z - 1.2 * h || z > v.centre.z + 0.4 * h) continue;
      const double c = cost[i - 1][j - 1] + std::fabs(z - expected) / h;
      if (c < cost[i][j]) cost[i][j] = c, how[i][j] = 2;
    }
  }
  std::vector<int> match(nv, -1);
  for (std::size_t i = nv, j = np; i > 0;) {
    if (how[i][j] == 2)
      match[i - 1] = static_cast<int>(j - 1), --i, --j;
    else if (how[i][j] == 1)
      --j;
    else
      --i;
  }
  return match;
}

// The index z range of the process's distal end whose profile peak is `p`: from the top of the
// peak's plateau through it and on down while the profile keeps coming forward (no flat longer
// than kLongestFlatMm), never below index z
// `valley` (the lowest profile between this peak and the one below).
std::pair<double, double> end_face(const std::vector<double>& post, const Peak& p, double valley,
                                   const Vec3& spacing) {
  const auto size = static_cast<std::int64_t>(post.size());
  auto top = static_cast<std::int64_t>(std::lround(p.z)), bottom = top;
  while (top + 1 < size && post[static_cast<std::size_t>(top + 1)] == p.y) ++top;
  while (bottom > 0 && post[static_cast<std::size_t>(bottom - 1)] == p.y) --bottom;
  const auto floor = static_cast<std::int64_t>(std::lround(valley));
  std::int64_t last_forward = bottom;  // the lowest slice reached by coming forward
  for (std::int64_t z = bottom; z > floor; --z) {
    const double here = post[static_cast<std::size_t>(z)];
    const double below = post[static_cast<std::size_t>(z - 1)];
    if (!std::isfinite(below)) break;
    const double forward = (here - below) * spacing[1];
    if (forward < 0.0 || forward > kSteepestEnd * spacing[2]) break;
    if (forward > 0.0) last_forward = z - 1;
    if (static_cast<double>(last_forward - (z - 1)) * spacing[2] > kLongestFlatMm) break;
  }
  bottom = last_forward;
  return {static_cast<double>(bottom), static_cast<double>(top)};
}

// The profile at a fractional index z (linear between slices).
double profile_at(const std::vector<double>& post, double z) {
  const auto lo = static_cast<std::size_t>(std::floor(z));
  const std::size_t hi = std::min(lo + 1, post.size() - 1);
  const double t = z - static_cast<double>(lo);
  if (!std::isfinite(post[hi])) return post[lo];
  return post[lo] + (post[hi] - post[lo]) * t;
}

}  // namespace

void find_spinous_tips(const PatientMask& bone, const std::vector<ColumnSlice>& column,
                       std::vector<VertebraSegment>& segments) {
  const std::vector<double> post = posterior_profile(bone, column);
  const std::vector<Peak> peaks = find_peaks(post, kInterspinousDropMm / bone.spacing[1]);
  std::vector<VertebraSegment*> verts;
  for (VertebraSegment& seg : segments)
    if (!seg.sacrum) verts.push_back(&seg);
  const std::vector<int> match = match_peaks(verts, peaks);
  const auto half = std::max<std::int64_t>(1, std::lround(kSlabHalfWidthMm / bone.spacing[0]));
  for (std::size_t v = 0; v < verts.size(); ++v) {
    if (match[v] < 0) continue;
    const auto m = static_cast<std::size_t>(match[v]);
    const Peak& p = peaks[m];
    // The valley under the peak: the lowest profile between it and the peak below.
    double valley = m > 0 ? peaks[m - 1].z : 0.0, low = 1e30;
    for (auto z = static_cast<std::size_t>(std::lround(valley));
         z <= static_cast<std::size_t>(std::lround(p.z)); ++z)
      if (std::isfinite(post[z]) && post[z] <= low) low = post[z], valley = static_cast<double>(z);
    const auto [bottom, top] = end_face(post, p, valley, bone.spacing);
    const double tz = 0.5 * (bottom + top), ty = profile_at(post, tz);
    const auto z = std::lround(tz);
    const ColumnSlice& c = column[static_cast<std::size_t>(z)];
    double sx = 0.0, n = 0.0;
    const auto xc = std::lround(c.x);
    for (std::int64_t x = xc - half; x <= xc + half; ++x)
      if (bone.at(x, std::lround(ty), z)) sx += static_cast<double>(x), n += 1.0;
    // The tip is the bone's posterior surface: half a voxel behind the last bone voxel's centre.
    verts[v]->spinous_tip = Vec3d{n > 0.0 ? sx / n : c.x, ty + 0.5, tz};
  }
}

}  // namespace palp::anatomy
