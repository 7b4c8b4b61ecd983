// Is this volume plausibly a CT in Hounsfield units? prep asks before it segments, so a CT saved
// without its rescale (air near 0 or +24, water near +1024), a label map or an MR is refused
// with what was seen, instead of prepping into litres of "body" or "bone".
//
// Looked at: the fraction of voxels that are air (-1100..-900 HU: a CT has air around the
// patient), the fraction that is soft tissue or water (-100..+150 HU), the value range and the
// number of distinct values (a label map has a handful). After segmentation, the fraction of the
// grid the body fills (a CT shows air around the patient).
#pragma once

#include <cstdint>
#include <string>

#include "base/volume.hpp"

namespace palp {

struct CtCheck {
  double air_fraction = 0.0;   // of all voxels, in [-1100, -900] HU
  double soft_fraction = 0.0;  // of all voxels, in [-100, +150] HU
  std::int16_t min_hu = 0, max_hu = 0;
  std::uint32_t distinct_values = 0;  // counted up to 65536
  bool plausible = false;
  std::string finding;  // empty when plausible: what was seen and what it suggests
};

inline constexpr double kMinAirFraction = 0.005;
inline constexpr double kMinSoftFraction = 0.02;
inline constexpr double kMaxBodyFraction = 0.95;

CtCheck check_hu(const CtVolume& ct);

// The message prep refuses with: the input, the finding, and how to override.
std::string not_a_ct_message(const std::string& input, const CtCheck& check);

// After segmentation: empty when the body fills at most kMaxBodyFraction of the grid, else the
// finding (there is no air around the patient: not a CT in HU, or a CT cropped inside the body).
std::string check_body_fraction(std::uint64_t body_voxels, const Grid& grid);

}  // namespace palp
