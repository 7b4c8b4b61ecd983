// Bone's HU levels from the scan itself (issue: thresholds that adapt to the scan).
//
// Fixed HU levels assume a calibrated scanner: soft tissue (muscle, liver, spleen, kidney) near
// 40-60 HU. A scanner's calibration, its kernel, beam hardening and the contrast phase move that
// peak by tens of HU, and every bone level fixed in HU moves with it relative to the tissue it
// has to separate bone from. So prep measures the soft-tissue peak of the HU histogram inside the
// body and shifts the bone levels by its offset from 50 HU; what it found and chose is recorded
// in prep.json ("hu_levels").
//
//   histogram   body voxels, 1 HU bins, smoothed with a 9 HU box
//   peak        the mode between -30 and 150 HU (fat lies below, contrast-filled vessels and
//               bone above); none when that range holds under 1 % of the body
//   offset      peak - 50 HU, limited to +-40 HU (a scan off by more is not a calibration error
//               this should follow: the levels stay at the nominal ones and prep.json says so)
//   levels      bone_seed, bone_grow and the bone iso level, each nominal + offset
#pragma once

#include <string>

#include "base/volume.hpp"

namespace palp {

struct BoneLevels {
  double seed_hu = 300.0;
  double grow_hu = 150.0;
  double iso_hu = 200.0;
};

struct HuLevels {
  bool peak_found = false;
  double soft_peak_hu = 0.0;  // the mode, when found
  double peak_share = 0.0;    // share of body voxels between -30 and 150 HU
  double offset_hu = 0.0;     // applied to the nominal levels (0 when not found or out of range)
  std::string note;           // why the offset is 0, when it is
  BoneLevels levels;          // nominal + offset
};

inline constexpr double kNominalSoftTissueHu = 50.0;
inline constexpr double kMaxCalibrationOffsetHu = 40.0;

// The levels for `ct` given its body mask (same grid; UsageError otherwise), from `nominal`.
HuLevels estimate_hu_levels(const CtVolume& ct, const Mask& body, const BoneLevels& nominal = {});

}  // namespace palp
