// The vertebral column split at its discs (spine_levels.hpp): the anterior column's bone profile
// along its centre line, in sections perpendicular to it, so a tilted disc (L5/S1 meets the
// axial plane at 20-40 degrees) is still a gap.
#include "anatomy/spine_levels.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "anatomy/spine_internal.hpp"

namespace palp::anatomy {
namespace {

// A section reaches this far from the centre line (mm): inside the smallest vertebral body of
// the thoracolumbar spine (T1's is about 25 mm wide and 15 mm deep), laterally and
// anteroposteriorly (the latter at most 30 % of the body's own depth).
constexpr double kSectionHalfWidthMm = 8.0;
// Between two discs lies a vertebra at least this tall (mm; C3's body is about 12 mm, the
// thoracolumbar ones 17-30 mm): a shorter run of bone is part of a neighbour.
constexpr double kMinVertebraMm = 12.0;

Vec3d centre_mm(const PatientMask& b, const ColumnSlice& c, std::int64_t z) {
  return {c.x * b.spacing[0], c.y * b.spacing[1], static_cast<double>(z) * b.spacing[2]};
}

// The unit tangent of the centre line at slice z (a difference over about 6 mm each way).
Vec3d tangent(const PatientMask& b, const std::vector<ColumnSlice>& column, std::int64_t z,
              std::int64_t lo, std::int64_t hi) {
  const auto k = std::max<std::int64_t>(1, std::lround(6.0 / b.spacing[2]));
  const std::int64_t z0 = std::max(lo, z - k), z1 = std::min(hi, z + k);
  const Vec3d d = centre_mm(b, column[static_cast<std::size_t>(z1)], z1) -
                  centre_mm(b, column[static_cast<std::size_t>(z0)], z0);
  const double n = norm(d);
  return n > 0.0 ? d * (1.0 / n) : Vec3d{0.0, 0.0, 1.0};
}

ProfileSample section(const PatientMask& b, const Vec3d& at_mm, const Vec3d& t, double half_ap) {
  Vec3d e1 = Vec3d{1.0, 0.0, 0.0} - t * t.x;
  e1 = e1 * (1.0 / norm(e1));
  const Vec3d e2 = cross(t, e1);
  const double h = std::min(1.0, 0.5 * std::min({b.spacing[0], b.spacing[1], b.spacing[2]}));
  ProfileSample s;
  s.z = at_mm.z / b.spacing[2];
  double points = 0.0;
  for (double u = -kSectionHalfWidthMm; u <= kSectionHalfWidthMm + 1e-9; u += h)
    for (double v = -half_ap; v <= half_ap + 1e-9; v += h) {
      const Vec3d p = at_mm + e1 * u + e2 * v;
      const Vec3d idx{p.x / b.spacing[0], p.y / b.spacing[1], p.z / b.spacing[2]};
      points += 1.0;
      if (!b.at(std::lround(idx.x), std::lround(idx.y), std::lround(idx.z))) continue;
      s.bone_points += 1.0;
      s.bone_sum += idx;
    }
  s.fraction = points > 0.0 ? s.bone_points / points : 0.0;
  return s;
}

}  // namespace

std::vector<ProfileSample> column_profile(const PatientMask& b,
                                          const std::vector<ColumnSlice>& column) {
  std::int64_t lo = -1, hi = -1;
  for (std::size_t z = 0; z < column.size(); ++z)
    if (column[z].on_column)
      (lo < 0 ? lo : hi) = static_cast<std::int64_t>(z), hi = static_cast<std::int64_t>(z);
  std::vector<ProfileSample> out;
  if (lo < 0 || hi <= lo) return out;
  for (std::int64_t z = lo; z < hi; ++z) {
    const Vec3d a = centre_mm(b, column[static_cast<std::size_t>(z)], z);
    const Vec3d c = centre_mm(b, column[static_cast<std::size_t>(z + 1)], z + 1);
    const double length = norm(c - a);
    const auto steps = std::max<std::int64_t>(1, std::lround(length / kProfileStepMm));
    const Vec3d ta = tangent(b, column, z, lo, hi), tc = tangent(b, column, z + 1, lo, hi);
    for (std::int64_t s = 0; s < steps; ++s) {
      const double f = static_cast<double>(s) / static_cast<double>(steps);
      Vec3d t = ta * (1.0 - f) + tc * f;
      t = t * (1.0 / norm(t));
      const double depth_mm = (column[static_cast<std::size_t>(z)].depth * (1.0 - f) +
                               column[static_cast<std::size_t>(z + 1)].depth * f) *
                              b.spacing[1];
      out.push_back(section(b, a * (1.0 - f) + c * f, t,
                            std::clamp(0.3 * depth_mm, b.spacing[1], kSectionHalfWidthMm)));
    }
  }
  return out;
}

namespace {

struct Gap {
  std::size_t first = 0, last = 0;  // profile samples below the threshold
  double lowest = 0.0;              // the smallest fraction in it
};

std::vector<Gap> find_gaps(const std::vector<ProfileSample>& profile, double threshold) {
  std::vector<Gap> gaps;
  for (std::size_t s = 0; s < profile.size(); ++s) {
    if (profile[s].fraction >= threshold) continue;
    if (!gaps.empty() && gaps.back().last + 1 == s) {
      gaps.back().last = s;
      gaps.back().lowest = std::min(gaps.back().lowest, profile[s].fraction);
    } else {
      gaps.push_back({s, s, profile[s].fraction});
    }
  }
  // Empty ends are not discs: the column's ends.
  if (!gaps.empty() && gaps.front().first == 0) gaps.erase(gaps.begin());
  if (!gaps.empty() && gaps.back().last + 1 == profile.size()) gaps.pop_back();
  return gaps;
}

// Drops the shallower disc of each vertebra shorter than kMinVertebraMm until none is.
void merge_short(std::vector<Gap>& gaps, std::size_t samples) {
  while (true) {
    std::size_t worst = gaps.size();
    for (std::size_t g = 0; g + 1 < gaps.size(); ++g) {
      const double mm = static_cast<double>(gaps[g + 1].first - gaps[g].last) * kProfileStepMm;
      if (mm >= kMinVertebraMm) continue;
      worst = gaps[g].lowest > gaps[g + 1].lowest ? g : g + 1;
      break;
    }
    if (worst == gaps.size()) break;
    gaps.erase(gaps.begin() + static_cast<std::ptrdiff_t>(worst));
  }
  // An end piece shorter than half a vertebra is no vertebra of its own: the gap goes.
  if (!gaps.empty() &&
      static_cast<double>(gaps.front().first) * kProfileStepMm < 0.5 * kMinVertebraMm)
    gaps.erase(gaps.begin());
  if (!gaps.empty() &&
      static_cast<double>(samples - 1 - gaps.back().last) * kProfileStepMm < 0.5 * kMinVertebraMm)
    gaps.pop_back();
}

// A vertebra half again as tall as the median of the others holds a disc the threshold missed
// (a thin disc, partial volume at a coarse slice spacing): the deepest dip near its middle,
// if the bone falls there by a tenth of the body's level, is that disc.
void split_tall(std::vector<Gap>& gaps, const std::vector<ProfileSample>& profile, double high) {
  for (int round = 0; round < 16; ++round) {
    std::vector<std::pair<std::size_t, std::size_t>> pieces;  // first, last sample
    std::size_t from = 0;
    for (std::size_t g = 0; g <= gaps.size(); ++g) {
      const std::size_t to = g < gaps.size() ? gaps[g].first - 1 : profile.size() - 1;
      pieces.emplace_back(from, to);
      if (g < gaps.size()) from = gaps[g].last + 1;
    }
    if (pieces.size() < 3) return;
    std::vector<double> heights;
    for (std::size_t i = 1; i + 1 < pieces.size(); ++i)
      heights.push_back(static_cast<double>(pieces[i].second - pieces[i].first + 1));
    std::nth_element(heights.begin(),
                     heights.begin() + static_cast<std::ptrdiff_t>(heights.size() / 2),
                     heights.end());
    const double median = heights[heights.size() / 2];
    bool split = false;
    for (std::size_t i = 0; i < pieces.size() && !split; ++i) {
      const auto [a, b] = pieces[i];
      if (static_cast<double>(b - a + 1) < 1.5 * median) continue;
      const auto margin = static_cast<std::size_t>(0.3 * median);
      std::size_t best = 0;
      double lowest = 2.0;
      for (std::size_t s = a + margin; s + margin <= b; ++s)
        if (profile[s].fraction < lowest) lowest = profile[s].fraction, best = s;
      if (lowest > 0.9 * high) continue;
      double left = 0.0, right = 0.0;
      for (std::size_t s = a; s < best; ++s) left = std::max(left, profile[s].fraction);
      for (std::size_t s = best + 1; s <= b; ++s) right = std::max(right, profile[s].fraction);
      if (std::min(left, right) - lowest < 0.1 * high) continue;
      const auto at = std::lower_bound(gaps.begin(), gaps.end(), best,
                                       [](const Gap& g, std::size_t s) { return g.last < s; });
      gaps.insert(at, Gap{best, best, lowest});
      split = true;
    }
    if (!split) return;
  }
}

VertebraSegment make_segment(const std::vector<ProfileSample>& profile, std::size_t from,
                             std::size_t to, double high) {
  VertebraSegment seg;
  Vec3d sum{};
  double n = 0.0;
  for (std::size_t s = from; s <= to; ++s) sum += profile[s].bone_sum, n += profile[s].bone_points;
  seg.centre = n > 0.0 ? sum * (1.0 / n) : Vec3d{};
  seg.height_mm = static_cast<double>(to - from + 1) * kProfileStepMm;
  (void)high;
  return seg;
}

}  // namespace

std::vector<VertebraSegment> split_at_discs(const PatientMask& b,
                                            const std::vector<ColumnSlice>& column,
                                            const std::vector<ProfileSample>& profile) {
  std::vector<VertebraSegment> segments;
  if (profile.size() < 2) return segments;
  std::vector<double> fractions;
  for (const ProfileSample& s : profile) fractions.push_back(s.fraction);
  const auto p80 = fractions.begin() + static_cast<std::ptrdiff_t>(fractions.size() * 4 / 5);
  std::nth_element(fractions.begin(), p80, fractions.end());
  const double high = *p80;
  if (!(high > 0.0)) return segments;
  std::vector<Gap> gaps = find_gaps(profile, 0.5 * high);
  merge_short(gaps, profile.size());
  split_tall(gaps, profile, high);
  std::size_t from = 0;
  double below_clarity = 1.0;
  const double z_top = static_cast<double>(b.dims[2] - 1);
  for (std::size_t g = 0; g <= gaps.size(); ++g) {
    const std::size_t to = g < gaps.size() ? gaps[g].first - 1 : profile.size() - 1;
    VertebraSegment seg = make_segment(profile, from, to, high);
    const std::size_t lo_sample = g == 0 ? 0 : (gaps[g - 1].first + gaps[g - 1].last) / 2;
    const std::size_t hi_sample = g < gaps.size() ? (gaps[g].first + gaps[g].last) / 2 : to;
    seg.z_lo = profile[lo_sample].z, seg.z_hi = profile[hi_sample].z;
    const double above_clarity = g < gaps.size() ? 1.0 - gaps[g].lowest / high : 1.0;
    seg.gap_clarity = std::clamp(std::min(below_clarity, above_clarity), 0.0, 1.0);
    seg.cut =
        (g == 0 && profile.front().z < 1.0) || (g == gaps.size() && profile.back().z > z_top - 1.0);
    below_clarity = above_clarity;
    segments.push_back(seg);
    if (g < gaps.size()) from = gaps[g].last + 1;
  }
  (void)column;
  return segments;
}

namespace {

// The sacrum's body centre is S1's: the bone of its top vertebra's height (the median of the
// vertebrae above), not the centroid of the whole curved sacrum.
void s1_centre(const std::vector<ProfileSample>& profile, VertebraSegment& sacrum,
               const std::vector<VertebraSegment>& segments) {
  std::vector<double> heights;
  for (const VertebraSegment& s : segments)
    if (!s.sacrum) heights.push_back(s.z_hi - s.z_lo);
  if (heights.empty()) return;
  std::nth_element(heights.begin(),
                   heights.begin() + static_cast<std::ptrdiff_t>(heights.size() / 2),
                   heights.end());
  const double from = sacrum.z_hi - heights[heights.size() / 2];
  Vec3d sum{};
  double n = 0.0;
  for (const ProfileSample& p : profile)
    if (p.z >= from && p.z < sacrum.z_hi) sum += p.bone_sum, n += p.bone_points;
  if (n > 0.0) sacrum.centre = sum * (1.0 / n);
}

}  // namespace

Spine find_spine(const PatientMask& bone, const std::vector<SliceBody>& bodies) {
  Spine spine;
  spine.column = find_column(bone, bodies);
  const std::vector<ProfileSample> profile = column_profile(bone, spine.column);
  spine.segments = split_at_discs(bone, spine.column, profile);
  if (spine.segments.empty()) {
    spine.notes.push_back("No vertebral column was found near the posterior midline.");
    spine.sacrum_reason = "no vertebral column in the scan";
    return spine;
  }
  measure_widths(bone, spine.column, spine.segments);
  find_sacrum(spine);
  if (spine.sacrum >= 0)
    s1_centre(profile, spine.segments[static_cast<std::size_t>(spine.sacrum)], spine.segments);
  find_spinous_tips(bone, spine.column, spine.segments);
  return spine;
}

int segment_at(const Spine& spine, double z) {
  for (std::size_t s = 0; s < spine.segments.size(); ++s)
    if (z >= spine.segments[s].z_lo && z < spine.segments[s].z_hi) return static_cast<int>(s);
  return -1;
}

}  // namespace palp::anatomy
