// CT plausibility checks before and after segmentation: see ct_check.hpp.
#include "prep/ct_check.hpp"

#include <cstdio>
#include <vector>

namespace palp {
namespace {

std::string percent(double fraction) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f%%", 100.0 * fraction);
  return text;
}

}  // namespace

CtCheck check_hu(const CtVolume& ct) {
  CtCheck c;
  if (ct.data.empty()) {
    c.finding = "the volume is empty";
    return c;
  }
  std::vector<std::uint64_t> histogram(65536, 0);
  for (std::int16_t v : ct.data) ++histogram[static_cast<std::uint16_t>(v)];
  std::uint64_t air = 0, soft = 0;
  bool first = true;
  for (int v = -32768; v <= 32767; ++v) {
    const std::uint64_t n = histogram[static_cast<std::uint16_t>(static_cast<std::int16_t>(v))];
    if (n == 0) continue;
    ++c.distinct_values;
    if (first) c.min_hu = static_cast<std::int16_t>(v), first = false;
    c.max_hu = static_cast<std::int16_t>(v);
    if (v >= -1100 && v <= -900) air += n;
    if (v >= -100 && v <= 150) soft += n;
  }
  const double total = static_cast<double>(ct.data.size());
  c.air_fraction = static_cast<double>(air) / total;
  c.soft_fraction = static_cast<double>(soft) / total;
  c.plausible = c.air_fraction >= kMinAirFraction && c.soft_fraction >= kMinSoftFraction;
  if (c.plausible) return c;

  std::string seen = percent(c.air_fraction) + " of voxels are air (-1100..-900 HU), " +
                     percent(c.soft_fraction) + " soft tissue (-100..+150 HU), values " +
                     std::to_string(c.min_hu) + ".." + std::to_string(c.max_hu) + " in " +
                     std::to_string(c.distinct_values) + " distinct values";
  std::string guess;
  if (c.distinct_values <= 16 && c.min_hu >= 0 && c.max_hu <= 255)
    guess = "it looks like a label map or a mask, not a CT";
  else if (c.min_hu >= -100 && c.max_hu > 900)
    guess =
        "air near 0 and water near +1024 suggest a CT saved without its rescale (add the "
        "intercept -1024: NIfTI scl_inter, DICOM RescaleIntercept)";
  else if (c.min_hu >= -100)
    guess = "no value is near air (-1000 HU): an MR or another modality, or a CT without rescale";
  else
    guess = "a CT has air around the patient and soft tissue near 0..100 HU";
  c.finding = seen + "; " + guess;
  return c;
}

std::string not_a_ct_message(const std::string& input, const CtCheck& check) {
  return input + ": does not look like a CT in Hounsfield units: " + check.finding +
         ". To prep it anyway: palp prep --not-hu-ok INPUT --out DIR (then use DIR as the scene)";
}

std::string check_body_fraction(std::uint64_t body_voxels, const Grid& grid) {
  const double fraction =
      static_cast<double>(body_voxels) / static_cast<double>(grid.voxel_count());
  if (fraction <= kMaxBodyFraction) return {};
  return "the body fills " + percent(fraction) + " of the grid (at most " +
         percent(kMaxBodyFraction) +
         " expected: a CT shows air around the patient); not a CT in HU, or a CT cropped inside "
         "the body";
}

}  // namespace palp
