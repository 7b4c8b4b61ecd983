// Bone's HU levels from the scan itself (issue: thresholds that adapt to the scan).
//
// Fixed HU levels assume a calibrated scanner: soft tissue (muscle, liver, spleen, kidney) near
// 40-60 HU. A scanner's calibration, its kernel and beam hardening move that peak by tens of HU,
// and every bone level fixed in HU moves with it relative to the tissue it has to separate bone
// from. So prep measures the soft-tissue peak of the HU histogram inside the body and shifts the
// bone levels by its offset from 50 HU. Contrast also raises that peak (the organs enhance), but
// not bone or fat: a rise is followed only as far as the fat peak rose too. What it found and
// chose is recorded in prep.json ("hu_levels").
//
//   histogram   body voxels, 1 HU bins, smoothed with a 9 HU box
//   peak        the mode between -30 and 150 HU (fat lies below, contrast-filled vessels and
//               bone above); none when that range holds under 1 % of the body
//   fat         the mode between -150 and -50 HU, when that range holds 1 % of the body or more
//   offset      peak - 50 HU, limited to +-40 HU (a scan off by more is not a calibration error
//               this should follow: the levels stay at the nominal ones and prep.json says so);
//               a rise more than 10 HU larger than the fat's (fat - (-100 HU); 0 without a fat
//               peak) is cut to the fat's rise, or to 0 if the fat fell; a fall is followed as it
//               is (measured on the shared CT: docs/prep.md, "Bone levels from the scan")
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
  bool fat_found = false;
  double fat_peak_hu = 0.0;  // the fat mode (-150..-50 HU), when found
  double fat_share = 0.0;    // share of body voxels between -150 and -50 HU
  double offset_hu = 0.0;    // applied to the nominal levels (0 when not found or out of range)
  std::string note;          // why the offset is 0, when it is
  BoneLevels levels;         // nominal + offset
};

inline constexpr double kNominalSoftTissueHu = 50.0;
inline constexpr double kNominalFatHu = -100.0;
inline constexpr double kMaxCalibrationOffsetHu = 40.0;

// The levels for `ct` given its body mask (same grid; UsageError otherwise), from `nominal`.
HuLevels estimate_hu_levels(const CtVolume& ct, const Mask& body, const BoneLevels& nominal = {});

}  // namespace palp
