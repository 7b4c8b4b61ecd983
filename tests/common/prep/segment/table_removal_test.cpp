// Table removal (common/prep/segment/table_removal.cpp, called from segment_body): the table, pad
// and cables are not body whichever side of the patient they lie on. A prone patient's table lies
// in front (on the frame's anterior side); the patient's frame does not say where gravity pointed,
// so segment_body looks for the bands from both sides.
#include <gtest/gtest.h>

#include <cstdint>

#include "prep/segment/segmentation.hpp"
#include "support/torso_scenes.hpp"

namespace palp {
namespace {

using testing::coarse_torso;
using testing::turned_about_body_axis;

TEST(TableRemoval, ATableInFrontOfAPronePatientIsRemovedToo) {
  const CtVolume supine = coarse_torso();
  SegmentationStats supine_stats, prone_stats;
  const Mask body = segment_body(supine, SegmentationParams{}, &supine_stats);
  const Mask prone_body =
      segment_body(turned_about_body_axis(supine), SegmentationParams{}, &prone_stats);
  ASSERT_GT(supine_stats.table_voxels, 1000u) << "the phantom has no table to find: no test";
  EXPECT_EQ(prone_stats.table_voxels, supine_stats.table_voxels);
  const Mask back = turned_about_body_axis(prone_body);
  std::int64_t differ = 0;
  for (std::size_t n = 0; n < body.data.size(); ++n) differ += body.data[n] != back.data[n];
  EXPECT_EQ(differ, 0);
}

}  // namespace
}  // namespace palp
