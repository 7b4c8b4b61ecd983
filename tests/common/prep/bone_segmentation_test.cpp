// The bone mask (common/prep/bone_segmentation.cpp) against the expert labels of the shared CT
// (../shared/data/ct_abdomen_3mm_reference_labels.nii.gz: 1 organs, 2 bone), measured only: the
// labels never enter the segmentation. Skips when the data is absent.
#include <gtest/gtest.h>

#include <cstdlib>

#include <cstdio>
#include <filesystem>
#include <string>

#include "io/ct_io.hpp"
#include "prep/hu_levels.hpp"
#include "prep/segmentation.hpp"
#include "support/mask_metrics.hpp"

namespace palp {
namespace {

struct Measured {
  double dice = 0.0;
  double precision = 0.0;  // of the segmented bone, the share the experts call bone
  double recall = 0.0;     // of the experts' bone, the share segmented
  double assd_mm = 0.0;
  double superficial_recall = 0.0;  // see below
  std::int64_t superficial_voxels = 0;
  std::int64_t organ_voxels_outside_body = 0;
};

// Superficial anterolateral bone, where palpation feels ribs, costal cartilage and the iliac
// crests: expert bone voxels within 30 mm of the body's outside and not in the posterior 30 % of
// the body's extent along the posterior axis in their slice (the spine's processes).
Mask superficial_bone(const Mask& truth_bone, const Mask& body) {
  const Grid& g = body.grid;
  const PatientAxes axes = patient_axes(g);
  Mask outside = body;
  for (auto& v : outside.data) v = v ? 0 : 1;
  const std::vector<double> to_outside = testing::squared_distance_to(outside);
  Mask out(g, 0);
  for (std::int64_t s = 0; s < g.dims[axes.slice]; ++s) {
    std::int64_t lo = g.dims[axes.posterior], hi = -1;
    Index3 at{};
    at[axes.slice] = s;
    auto each = [&](auto fn) {
      for (std::int64_t p = 0; p < g.dims[axes.posterior]; ++p)
        for (std::int64_t l = 0; l < g.dims[axes.lateral]; ++l) {
          at[axes.posterior] = p;
          at[axes.lateral] = l;
          fn(p, g.linear(at[0], at[1], at[2]));
        }
    };
    each([&](std::int64_t p, std::size_t n) {
      if (body.data[n]) lo = std::min(lo, p), hi = std::max(hi, p);
    });
    if (hi < 0) continue;
    const double extent = static_cast<double>(hi - lo);
    each([&](std::int64_t p, std::size_t n) {
      if (!truth_bone.data[n] || to_outside[n] > 30.0 * 30.0) return;
      const double towards_back =
          axes.posterior_increasing ? static_cast<double>(p - lo) : static_cast<double>(hi - p);
      if (towards_back <= 0.7 * extent) out.data[n] = 1;
    });
  }
  return out;
}

TEST(BoneSegmentation, AgainstExpertLabelsOfTheSharedCt) {
  const std::string dir = PALP_SHARED_DATA_DIR;
  const std::string ct_path = dir + "/ct_abdomen_3mm.nii.gz";
  const std::string labels_path = dir + "/ct_abdomen_3mm_reference_labels.nii.gz";
  if (!std::filesystem::exists(ct_path) || !std::filesystem::exists(labels_path))
    GTEST_SKIP() << "the shared CT or its labels are not in " << dir;
  const CtVolume ct = read_ct(ct_path);
  const DistanceMap labels = read_nifti_float(labels_path);  // 0, 1, 2 as read
  ASSERT_EQ(labels.grid.dims, ct.grid.dims);
  SegmentationParams params;
  const Mask body = segment_body(ct, params);
  // The levels as prep sets them: shifted with the scan's soft-tissue peak (prep/hu_levels.hpp).
  const HuLevels levels = estimate_hu_levels(ct, body);
  if (std::getenv("PALP_FIXED_BONE_LEVELS") == nullptr) {
    params.bone_seed_hu = levels.levels.seed_hu;
    params.bone_grow_hu = levels.levels.grow_hu;
    params.marrow_min_hu = levels.levels.marrow_min_hu;
  }
  std::printf("bone levels: seed %.0f, grow %.0f, marrow %.0f HU\n", params.bone_seed_hu,
              params.bone_grow_hu, params.marrow_min_hu);
  const Mask bone = segment_bone(ct, body, params);
  Mask truth_bone(ct.grid, 0), organs(ct.grid, 0);
  for (std::size_t n = 0; n < labels.data.size(); ++n) {
    truth_bone.data[n] = labels.data[n] == 2.0f;
    organs.data[n] = labels.data[n] == 1.0f;
  }
  Measured m;
  m.dice = testing::dice(bone, truth_bone);
  m.assd_mm = testing::mean_surface_distance(bone, truth_bone);
  const auto both = static_cast<double>(testing::count_both(bone, truth_bone));
  m.precision = both / static_cast<double>(testing::count(bone));
  m.recall = both / static_cast<double>(testing::count(truth_bone));
  m.organ_voxels_outside_body = testing::count_and_not(organs, body);
  const Mask superficial = superficial_bone(truth_bone, body);
  m.superficial_voxels = testing::count(superficial);
  m.superficial_recall = static_cast<double>(testing::count_both(superficial, bone)) /
                         static_cast<double>(m.superficial_voxels);
  std::printf(
      "bone vs experts: Dice %.3f, precision %.3f, recall %.3f, mean symmetric surface distance "
      "%.2f mm, superficial "
      "anterolateral (rib region) recall %.3f of %lld voxels; organ voxels outside the body %lld\n",
      m.dice, m.precision, m.recall, m.assd_mm, m.superficial_recall,
      static_cast<long long>(m.superficial_voxels),
      static_cast<long long>(m.organ_voxels_outside_body));
  EXPECT_EQ(m.organ_voxels_outside_body, 0);
  EXPECT_GT(m.superficial_voxels, 1000);
  // What the current method achieves (the goal, Dice >= 0.90 and <= 1.0 mm, is not met).
  // With the levels adapted (PALP_FIXED_BONE_LEVELS=1 measures the fixed ones: Dice 0.809,
  // precision 0.884, 1.73 mm, rib recall 0.759).
  if (std::getenv("PALP_FIXED_BONE_LEVELS") != nullptr) return;
  EXPECT_GE(m.dice, 0.83);
  EXPECT_LE(m.assd_mm, 1.77);
  EXPECT_GE(m.superficial_recall, 0.78);
  EXPECT_GE(m.precision, 0.84);  // over-segmentation (vessels, calcifications, table) stays rare
}

}  // namespace
}  // namespace palp
