#include "prep/hu_levels.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "base/errors.hpp"

namespace palp {
namespace {

constexpr int kLowHu = -1024, kHighHu = 3071;  // histogram range; beyond it clamped
constexpr int kPeakLo = -30, kPeakHi = 150;
constexpr int kSmoothHalfWidth = 4;  // 9 HU box

}  // namespace

HuLevels estimate_hu_levels(const CtVolume& ct, const Mask& body, const BoneLevels& nominal) {
  if (body.grid.dims != ct.grid.dims || body.data.size() != ct.data.size())
    throw UsageError("HU levels: the body mask is not on the CT's grid");
  std::vector<std::uint64_t> hist(static_cast<std::size_t>(kHighHu - kLowHu + 1), 0);
  std::uint64_t in_body = 0;
  for (std::size_t v = 0; v < ct.data.size(); ++v) {
    if (!body.data[v]) continue;
    const int hu = std::clamp(static_cast<int>(ct.data[v]), kLowHu, kHighHu);
    ++hist[static_cast<std::size_t>(hu - kLowHu)];
    ++in_body;
  }
  auto count = [&](int hu) { return hist[static_cast<std::size_t>(hu - kLowHu)]; };

  HuLevels out;
  out.levels = nominal;
  std::uint64_t in_range = 0;
  for (int hu = kPeakLo; hu <= kPeakHi; ++hu) in_range += count(hu);
  out.peak_share = in_body > 0 ? static_cast<double>(in_range) / static_cast<double>(in_body) : 0.0;
  if (in_body == 0 || out.peak_share < 0.01) {
    out.note = "no soft-tissue peak between -30 and 150 HU inside the body: nominal levels";
    return out;
  }
  std::uint64_t best = 0;
  int mode = kPeakLo;
  for (int hu = kPeakLo; hu <= kPeakHi; ++hu) {
    std::uint64_t s = 0;
    for (int d = -kSmoothHalfWidth; d <= kSmoothHalfWidth; ++d) s += count(hu + d);
    if (s > best) best = s, mode = hu;  // the first of equal maxima: deterministic
  }
  out.peak_found = true;
  out.soft_peak_hu = mode;
  const double offset = mode - kNominalSoftTissueHu;
  if (std::fabs(offset) > kMaxCalibrationOffsetHu) {
    out.note = "soft-tissue peak more than 40 HU from 50 HU: not followed, nominal levels";
    return out;
  }
  out.offset_hu = offset;
  out.levels.seed_hu = nominal.seed_hu + offset;
  out.levels.grow_hu = nominal.grow_hu + offset;
  out.levels.iso_hu = nominal.iso_hu + offset;
  return out;
}

}  // namespace palp
