// palp prep on the trunk phantom: its automatic bone, body and table segmentation find the bones
// the phantom's truth says are there (Dice against the truth bone mask, every vertebra's and rib's
// voxels covered), the body without the table, the arteries as contrast-filled vessels; and the
// same in another storage order. The trunk's landmarks are tested against this truth
// (io/phantom_trunk.hpp), so the truth must be what prep sees.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <string>

#include "io/ct_io.hpp"
#include "io/phantom.hpp"
#include "io/phantom_trunk.hpp"
#include "prep/prep.hpp"
#include "support/io_test_util.hpp"
#include "support/mask_metrics.hpp"

namespace palp {
namespace {

using testing::count;
using testing::dice;

struct Prepped {
  PhantomTruth truth;
  Mask bone, body, vessel;
  double seconds = 0.0;
};

Prepped prep_trunk(const std::string& spec) {
  testing::TempDir dir("prep-trunk");
  PhantomOptions options = parse_phantom_spec(spec).options;
  Prepped out;
  make_phantom("trunk", options, &out.truth);
  PrepParams params;
  params.use_cache = false;
  const auto start = std::chrono::steady_clock::now();
  run_prep("phantom:" + spec, dir.file("out"), params);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.bone = read_nifti_mask(dir.file("out/bone.nii.gz"));
  out.body = read_nifti_mask(dir.file("out/body.nii.gz"));
  out.vessel = read_nifti_mask(dir.file("out/vessel.nii.gz"));
  return out;
}

void expect_prep_finds_the_truth(const Prepped& p) {
  EXPECT_GT(dice(p.bone, p.truth.bone), 0.8);
  EXPECT_GT(dice(p.body, p.truth.body), 0.97);
  // the table and pad are not the patient
  EXPECT_EQ(testing::count_both(p.body, p.truth.equipment), 0);
  // each labelled bone mostly found
  std::map<std::uint8_t, std::array<std::int64_t, 2>> per;
  for (std::size_t i = 0; i < p.bone.size(); ++i) {
    const std::uint8_t l = p.truth.bone_label.data[i];
    if (l == 0) continue;
    per[l][0] += 1;
    per[l][1] += p.bone.data[i] != 0;
  }
  for (const auto& [label, n] : per) {
    const double covered = static_cast<double>(n[1]) / static_cast<double>(n[0]);
    EXPECT_GT(covered, 0.8) << trunk_label_name(label);
  }
  // the arteries are vessels, not bone
  EXPECT_GT(static_cast<double>(testing::count_both(p.vessel, p.truth.artery)),
            0.6 * static_cast<double>(count(p.truth.artery)));
  EXPECT_LT(static_cast<double>(testing::count_both(p.bone, p.truth.artery)),
            0.05 * static_cast<double>(count(p.truth.artery)));
  std::printf("vessel %lld voxels, of them truth bone %lld, truth artery %lld (of %lld)\n",
              static_cast<long long>(count(p.vessel)),
              static_cast<long long>(testing::count_both(p.vessel, p.truth.bone)),
              static_cast<long long>(testing::count_both(p.vessel, p.truth.artery)),
              static_cast<long long>(count(p.truth.artery)));
}

TEST(PrepTrunk, FindsTheTruthBonesBodyAndArteriesQuickly) {
  const Prepped p = prep_trunk("trunk");
  std::printf("prep phantom:trunk: %.2f s, bone Dice %.3f, body Dice %.4f\n", p.seconds,
              dice(p.bone, p.truth.bone), dice(p.body, p.truth.body));
  expect_prep_finds_the_truth(p);
  EXPECT_LT(p.seconds, 30.0);
}

TEST(PrepTrunk, TheSameStoredInAnotherOrder) {
  expect_prep_finds_the_truth(prep_trunk("trunk,orient=PIL"));
}

}  // namespace
}  // namespace palp
