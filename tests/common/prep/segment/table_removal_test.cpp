// Table removal (common/prep/segment/table_removal.cpp, called from segment_body): the table, pad
// and cables are not body whichever side of the patient they lie on. A prone patient's table lies
// in front (on the frame's anterior side); the patient's frame does not say where gravity pointed,
// so segment_body looks for the bands from both sides.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
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
  for (std::int64_t k = 0; k < g.dims[2]; ++k)         // a vertebra in the back, at the edge
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

// An arm resting on the pad near its end, the board running on to the scan's side edge (the torso
// phantom with both arms): past the arm, the pad's end and the board beyond it (32 mm to the edge)
// are too narrow to be a band by themselves, and the arm's contact parts them from the rest of the
// table. They are the table followed past the arm; the arm, its humerus and the torso stay.
TEST(TableRemoval, ThePadsEndBeyondAnArmRestingOnItIsTable) {
  Grid g;
  g.dims = {116, 64, 18};
  g.spacing = {2.0, 2.0, 10.0};  // 232 x 128 mm, 180 mm along the body: the piece holds 60 ml
  CtVolume ct(g, -1000, "arm on the pad's end");
  CtVolume patient(g, 0, "truth");  // 1: body, 2: humerus
  const auto arm = [](std::int64_t i, std::int64_t j, double r) {
    return std::hypot(static_cast<double>(i - 96), static_cast<double>(j) - 35.0) <= r;
  };
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        std::int16_t hu = -1000, truth = 0;
        if (j >= 56 && j < 59) hu = 300;              // carbon board across the whole width
        if (j >= 50 && j < 56 && i < 106) hu = -100;  // gel pad, ending 20 mm short of the edge
        if (j >= 15 && j < 50 && i >= 25 && i < 60) hu = 40, truth = 1;  // torso on the pad
        if (arm(i, j, 14.5)) hu = 40, truth = 1;      // the arm (58 mm) resting on the pad
        if (arm(i, j + 2, 5.0)) hu = 900, truth = 2;  // its humerus
        ct.at(i, j, k) = hu;
        patient.at(i, j, k) = truth;
      }
  const Mask body = segment_body(ct, SegmentationParams{});
  const Mask bone = segment_bone(ct, body, SegmentationParams{});
  std::int64_t table_kept = 0, patient_lost = 0, humerus = 0, humerus_bone = 0, other_bone = 0;
  for (std::size_t n = 0; n < body.data.size(); ++n) {
    table_kept += ct.data[n] > -500 && patient.data[n] == 0 && body.data[n];
    patient_lost += patient.data[n] != 0 && !body.data[n];
    humerus += patient.data[n] == 2;
    humerus_bone += patient.data[n] == 2 && bone.data[n];
    other_bone += patient.data[n] != 2 && bone.data[n];
  }
  EXPECT_EQ(table_kept, 0);
  EXPECT_EQ(patient_lost, 0);
  EXPECT_EQ(humerus_bone, humerus);
  EXPECT_EQ(other_bone, 0);
}

}  // namespace
}  // namespace palp
