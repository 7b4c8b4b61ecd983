// The shared 3 mm CT with its expert labels (../shared/data: 1 organs, 2 bone; TotalSegmentator,
// CC BY 4.0), and the bone mask's scores against them. The labels are measured against, never
// handed to the segmentation.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <string>

#include "io/ct_io.hpp"
#include "support/bone_error_split.hpp"
#include "support/mask_metrics.hpp"

namespace palp::testing {

struct LabelledCt {
  CtVolume ct;
  Mask truth_bone, organs;
};

// The shared CT and its labels; false when either file is absent (or, a failure of the calling
// test, when the labels are not on the CT's grid).
inline bool load_labelled_shared_ct(LabelledCt& d) {
  const std::string dir = PALP_SHARED_DATA_DIR;
  const std::string ct_path = dir + "/ct_abdomen_3mm.nii.gz";
  const std::string labels_path = dir + "/ct_abdomen_3mm_reference_labels.nii.gz";
  if (!std::filesystem::exists(ct_path) || !std::filesystem::exists(labels_path)) return false;
  d.ct = read_ct(ct_path);
  const DistanceMap labels = read_nifti_float(labels_path);  // 0, 1, 2 as read
  if (labels.grid.dims != d.ct.grid.dims) {
    ADD_FAILURE() << labels_path << " is not on the grid of " << ct_path;
    return false;
  }
  d.truth_bone = Mask(d.ct.grid, 0);
  d.organs = Mask(d.ct.grid, 0);
  for (std::size_t n = 0; n < labels.data.size(); ++n) {
    d.truth_bone.data[n] = labels.data[n] == 2.0f;
    d.organs.data[n] = labels.data[n] == 1.0f;
  }
  return true;
}

// Superficial anterolateral bone, where palpation feels ribs, costal cartilage and the iliac
// crests: expert bone voxels within 30 mm of the body's outside and not in the posterior 30 % of
// the body's extent along the posterior axis in their slice (the spine's processes).
inline Mask superficial_bone(const Mask& truth_bone, const Mask& body) {
  const std::vector<std::uint8_t> region = body_regions(body);
  Mask out(body.grid, 0);
  for (std::size_t n = 0; n < out.data.size(); ++n)
    out.data[n] = truth_bone.data[n] && region[n] == static_cast<std::uint8_t>(Region::superficial);
  return out;
}

struct BoneScore {
  double dice = 0.0;
  double precision = 0.0;   // of the segmented bone, the share the experts call bone
  double recall = 0.0;      // of the experts' bone, the share segmented
  double assd_mm = 0.0;     // mean symmetric surface distance
  double rib_recall = 0.0;  // recall of superficial_bone()
  std::int64_t organ_voxels_outside_body = 0;
};

inline BoneScore score_bone(const Mask& bone, const Mask& body, const Mask& truth_bone,
                            const Mask& organs) {
  BoneScore s;
  s.dice = dice(bone, truth_bone);
  s.assd_mm = mean_surface_distance(bone, truth_bone);
  const auto both = static_cast<double>(count_both(bone, truth_bone));
  s.precision = both / static_cast<double>(count(bone));
  s.recall = both / static_cast<double>(count(truth_bone));
  const Mask superficial = superficial_bone(truth_bone, body);
  s.rib_recall =
      static_cast<double>(count_both(superficial, bone)) / static_cast<double>(count(superficial));
  s.organ_voxels_outside_body = count_and_not(organs, body);
  return s;
}

}  // namespace palp::testing
