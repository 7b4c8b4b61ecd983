#include "prep/segment/hu_levels.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "base/errors.hpp"

namespace palp {
namespace {

constexpr int kLowHu = -1024, kHighHu = 3071;  // histogram range; beyond it clamped
constexpr int kPeakLo = -30, kPeakHi = 150;
constexpr int kFatLo = -150, kFatHi = -50;
constexpr int kSmoothHalfWidth = 4;  // 9 HU box
constexpr double kMinPeakShare = 0.01;
// How far the fat's offset may fall short of the soft tissue's and still confirm it: the two
// modes are estimated apart, each to a few HU.
constexpr double kFatAgreementHu = 10.0;

// The mode of `hist` (1 HU bins from kLowHu) between lo and hi, 9 HU box-smoothed; the first of
// equal maxima, so the result is deterministic.
int smoothed_mode(const std::vector<std::uint64_t>& hist, int lo, int hi) {
  auto count = [&](int hu) { return hist[static_cast<std::size_t>(hu - kLowHu)]; };
  std::uint64_t best = 0;
  int mode = lo;
  for (int hu = lo; hu <= hi; ++hu) {
    std::uint64_t s = 0;
    for (int d = -kSmoothHalfWidth; d <= kSmoothHalfWidth; ++d) s += count(hu + d);
    if (s > best) best = s, mode = hu;
  }
  return mode;
}

double share(const std::vector<std::uint64_t>& hist, int lo, int hi, std::uint64_t total) {
  std::uint64_t in_range = 0;
  for (int hu = lo; hu <= hi; ++hu) in_range += hist[static_cast<std::size_t>(hu - kLowHu)];
  return total > 0 ? static_cast<double>(in_range) / static_cast<double>(total) : 0.0;
}

std::string hu_text(double hu) {
  char text[32];
  std::snprintf(text, sizeof text, "%+.0f", hu);
  return text;
}

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
  HuLevels out;
  out.levels = nominal;
  out.peak_share = share(hist, kPeakLo, kPeakHi, in_body);
  out.fat_share = share(hist, kFatLo, kFatHi, in_body);
  if (out.fat_share >= kMinPeakShare) {
    out.fat_found = true;
    out.fat_peak_hu = smoothed_mode(hist, kFatLo, kFatHi);
  }
  if (in_body == 0 || out.peak_share < kMinPeakShare) {
    out.note = "no soft-tissue peak between -30 and 150 HU inside the body: nominal levels";
    return out;
  }
  const int mode = smoothed_mode(hist, kPeakLo, kPeakHi);
  out.peak_found = true;
  out.soft_peak_hu = mode;
  double offset = mode - kNominalSoftTissueHu;
  if (std::fabs(offset) > kMaxCalibrationOffsetHu) {
    out.note = "soft-tissue peak more than 40 HU from 50 HU: not followed, nominal levels";
    return out;
  }
  // Upward only as far as fat confirms (within kFatAgreementHu): a calibration offset moves fat
  // with soft tissue, contrast raises the organs (often the soft-tissue peak) and leaves fat and
  // bone where they were.
  if (offset > 0.0) {
    const double fat_offset = out.fat_found ? out.fat_peak_hu - kNominalFatHu : 0.0;
    if (fat_offset < offset - kFatAgreementHu) {
      const double raised = std::max(0.0, fat_offset);
      out.note = "soft-tissue peak " + hu_text(offset) + " HU from 50 HU, fat " +
                 (out.fat_found ? hu_text(fat_offset) + " HU from -100 HU" : "not found") +
                 ": levels raised by " + hu_text(raised) +
                 " HU only (contrast raises soft tissue, not fat or bone)";
      offset = raised;
    }
  }
  out.offset_hu = offset;
  out.levels.seed_hu = nominal.seed_hu + offset;
  out.levels.grow_hu = nominal.grow_hu + offset;
  out.levels.iso_hu = nominal.iso_hu + offset;
  return out;
}

}  // namespace palp
