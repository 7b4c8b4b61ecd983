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

// A crop through the trunk (a scan reconstructed on a small field of view, as the shared aorta
// case is): the lungs reach the sides of the scan, so their air counts as outside, and the back,
// 30 mm of muscle and a vertebra cut by the scan's back edge, is a thin wide run with that air in
// front, as a table is. A table lies inside the field of view with air, a pad or a board's shell
// behind it; the back cut by the edge stays body.
TEST(TableRemoval, ABackCutByTheScansEdgeIsNotATable) {
  Grid g;
  g.dims = {80, 80, 6};
  g.spacing = {2.0, 2.0, 2.0};
  CtVolume ct(g, 40, "crop");  // soft tissue everywhere: the body fills the field of view
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 20; j < 65; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i)
        if (i < 35 || i >= 45) ct.at(i, j, k) = -850;  // lungs, open at the sides
  for (std::int64_t k = 0; k < g.dims[2]; ++k)  // a vertebra in the back, at the edge
    for (std::int64_t j = 68; j < 80; ++j)
      for (std::int64_t i = 35; i < 45; ++i) ct.at(i, j, k) = 700;
  SegmentationStats stats;
  const Mask body = segment_body(ct, SegmentationParams{}, &stats);
  std::int64_t back = 0, back_body = 0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 65; j < 80; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        ++back;
        back_body += body.at(i, j, k);
      }
  EXPECT_EQ(stats.table_voxels, 0u);
  EXPECT_EQ(back_body, back);
}

}  // namespace
}  // namespace palp
