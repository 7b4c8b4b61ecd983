// The sacrum among the lowest vertebrae, and the names counted from it (spine_levels.hpp).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

#include "anatomy/spine_internal.hpp"

namespace palp::anatomy {
namespace {

// Bone across a joint's cartilage (the sacroiliac joint is 2-4 mm wide) counts as one piece.
constexpr double kJointGapMm = 6.0;

// The lateral extent (mm) of the bone through (x, y, z), gaps up to kJointGapMm bridged.
double bridged_width(const PatientMask& bone, std::int64_t x, std::int64_t y, std::int64_t z) {
  if (!bone.at(x, y, z)) return 0.0;
  const auto gap = static_cast<std::int64_t>(std::floor(kJointGapMm / bone.spacing[0]));
  std::int64_t ends[2] = {x, x};
  for (int side = 0; side < 2; ++side) {
    const std::int64_t step = side ? 1 : -1;
    std::int64_t at = x, missing = 0;
    while (bone.contains(at + step, y, z) && missing <= gap) {
      at += step;
      if (bone.at(at, y, z))
        ends[side] = at, missing = 0;
      else
        ++missing;
    }
  }
  return static_cast<double>(ends[1] - ends[0] + 1) * bone.spacing[0];
}

std::string vertebra_name(int from_sacrum) {
  // 1 = L5 ... 5 = L1, 6 = T12 ... 17 = T1, 18 = C7 ... 24 = C1
  if (from_sacrum <= 5) return "L" + std::to_string(6 - from_sacrum);
  if (from_sacrum <= 17) return "T" + std::to_string(18 - from_sacrum);
  return "C" + std::to_string(25 - from_sacrum);
}

}  // namespace

void measure_widths(const PatientMask& bone, const std::vector<ColumnSlice>& column,
                    std::vector<VertebraSegment>& segments) {
  // The widest extent through the body's centre rows that holds over 5 mm of slices (one noisy
  // slice does not make a sacrum).
  const auto span = std::max<std::int64_t>(1, std::lround(5.0 / bone.spacing[2]));
  for (VertebraSegment& seg : segments) {
    const auto z0 = static_cast<std::int64_t>(std::ceil(seg.z_lo));
    const auto z1 = static_cast<std::int64_t>(std::floor(seg.z_hi));
    std::vector<double> widths;
    for (std::int64_t z = z0; z <= z1; ++z) {
      if (z < 0 || z >= bone.dims[2]) continue;
      const ColumnSlice& c = column[static_cast<std::size_t>(z)];
      double w = 0.0;
      // The rows of the body's middle 70 % (the alae lie level with S1's body, the lumbar
      // transverse processes behind their bodies).
      const auto reach = std::max<std::int64_t>(1, std::lround(0.35 * c.depth));
      for (std::int64_t dy = -reach; dy <= reach; ++dy)
        w = std::max(w, bridged_width(bone, std::lround(c.x), std::lround(c.y) + dy, z));
      widths.push_back(w);
    }
    double best = 0.0;
    for (std::size_t i = 0; i < widths.size(); ++i) {
      double low = widths[i];
      for (std::size_t j = i; j < std::min(widths.size(), i + static_cast<std::size_t>(span)); ++j)
        low = std::min(low, widths[j]);
      best = std::max(best, low);
    }
    seg.width_mm = best;
  }
}

void find_sacrum(Spine& spine) {
  auto& segs = spine.segments;
  if (segs.size() < 2) {
    spine.sacrum_reason = "too few vertebrae in the scan to tell the sacrum by its width";
    return;
  }
  std::vector<double> widths;
  for (const VertebraSegment& s : segs) widths.push_back(s.width_mm);
  std::sort(widths.begin(), widths.end());
  const double reference = widths[(widths.size() - 1) * 3 / 10];  // the narrower bodies
  // The lowest wide segment among the lowest three (below it: the coccyx at most).
  std::size_t first = segs.size();
  std::vector<double> heights;
  for (const VertebraSegment& s : segs) heights.push_back(s.height_mm);
  std::nth_element(heights.begin(),
                   heights.begin() + static_cast<std::ptrdiff_t>(heights.size() / 2),
                   heights.end());
  const double median_height = heights[heights.size() / 2];
  // Wide with its alae, or, a narrower sacrum (alae apart from the ilia in the body's rows), the
  // five fused sacral vertebrae: at least twice a vertebra's height and still wider.
  const auto sacral = [&](const VertebraSegment& s) {
    return s.width_mm >= kSacrumWidthRatio * reference ||
           (s.width_mm >= kFusedSacrumWidthRatio * reference && !s.cut &&
            s.height_mm >= 2.0 * median_height);
  };
  for (std::size_t s = 0; s < std::min<std::size_t>(3, segs.size()); ++s)
    if (sacral(segs[s])) {
      first = s;
      break;
    }
  if (first == segs.size()) {
    spine.sacrum_reason =
        "no vertebra at the column's lower end is much wider than those above it (no alae joined "
        "to the iliac bones): the scan ends above the sacrum";
    return;
  }
  std::size_t last = first;
  while (last + 1 < segs.size() && segs[last + 1].width_mm >= kSacrumWidthRatio * reference &&
         last + 1 < first + 5)
    ++last;
  // The sacrum's fused pieces are one: the centre of their bodies, their extent.
  VertebraSegment sacrum = segs[first];
  Vec3d sum = sacrum.centre * sacrum.height_mm;
  for (std::size_t s = first + 1; s <= last; ++s) {
    sum += segs[s].centre * segs[s].height_mm;
    sacrum.height_mm += segs[s].height_mm;
    sacrum.z_hi = segs[s].z_hi;
    sacrum.width_mm = std::max(sacrum.width_mm, segs[s].width_mm);
    sacrum.gap_clarity = segs[s].gap_clarity;
  }
  sacrum.centre = sum * (1.0 / sacrum.height_mm);
  sacrum.sacrum = true;
  if (first > 0)
    spine.notes.push_back("Bone below the sacrum along the column (the coccyx) is not named.");
  segs.erase(segs.begin() + static_cast<std::ptrdiff_t>(first + 1),
             segs.begin() + static_cast<std::ptrdiff_t>(last + 1));
  segs[first] = sacrum;
  segs.erase(segs.begin(), segs.begin() + static_cast<std::ptrdiff_t>(first));
  spine.sacrum = 0;
  // Confidence in the sacrum: its width ratio from the threshold (0) to 2.2 (1).
  const double ratio = sacrum.width_mm / std::max(reference, 1e-9);
  spine.segments[0].confidence = std::clamp((ratio - 1.2) / (2.2 - 1.2), 0.0, 1.0);
}

void name_vertebrae(Spine& spine, std::optional<int> lowest_rib) {
  auto& segs = spine.segments;
  int base = -1, base_count = 0;  // a segment and its count from the sacrum (0 = the sacrum)
  double base_confidence = 0.0;
  if (spine.sacrum >= 0) {
    base = spine.sacrum, base_count = 0,
    base_confidence = segs[static_cast<std::size_t>(base)].confidence;
  } else if (lowest_rib) {
    base = *lowest_rib, base_count = 6, base_confidence = 0.6;
  }
  if (base < 0) {
    for (VertebraSegment& s : segs) {
      s.name.reset();
      s.confidence = 0.0;
      s.reason = "no sacrum and no rib-bearing vertebra in the scan to count from";
    }
    spine.notes.push_back(
        "The vertebrae are not numbered: the scan shows neither the sacrum nor a "
        "rib-bearing vertebra (" +
        spine.sacrum_reason + ").");
    return;
  }
  // A rib on the vertebra counted as L1 or a count where T12 bears none: transitional anatomy
  // or a missed disc or rib; the count from the sacrum stands, with less confidence.
  bool consistent = true;
  if (spine.sacrum >= 0 && lowest_rib && *lowest_rib - spine.sacrum != 6) consistent = false;
  if (!consistent) {
    const int count = *lowest_rib - spine.sacrum;
    spine.notes.push_back(
        "The lowest rib articulates with the " + std::to_string(count) +
        (count == 1   ? "st"
         : count == 2 ? "nd"
         : count == 3 ? "rd"
                      : "th") +
        " vertebra above the sacrum, not the 6th (T12): a transitional vertebra or a rib or disc "
        "the scan does not show; the vertebrae are counted from the sacrum.");
  }
  for (int s = 0; s < static_cast<int>(segs.size()); ++s) {
    VertebraSegment& seg = segs[static_cast<std::size_t>(s)];
    const int count = base_count + (s - base);
    if (count < 0 || count > 24) {
      seg.name.reset(), seg.confidence = 0.0;
      seg.reason = count < 0 ? "below the sacrum" : "above C1 by the count: a disc was missed";
      continue;
    }
    seg.name = count == 0 ? std::string("S") : vertebra_name(count);
    // The count's confidence: the base's, times how clear the faintest disc counted on the way
    // is (a faint disc may be a false one, or its neighbour missed): 0.5 + 0.5 clarity.
    double faintest = 1.0;
    for (int k = std::min(s, base); k <= std::max(s, base); ++k)
      faintest = std::min(faintest, segs[static_cast<std::size_t>(k)].gap_clarity);
    double c = base_confidence * (0.5 + 0.5 * faintest);
    if (!consistent) c *= 0.6;
    if (seg.cut) c *= 0.7;
    seg.confidence = std::clamp(c, 0.0, 1.0);
    seg.reason.clear();
    if (spine.sacrum < 0)
      seg.reason = "counted from the lowest rib-bearing vertebra (T12): no sacrum in the scan";
    if (!consistent) seg.reason = "the lowest rib is not on the vertebra counted as T12";
    if (seg.cut)
      seg.reason += std::string(seg.reason.empty() ? "" : "; ") + "cut by the scan's edge";
  }
}

}  // namespace palp::anatomy
