// Table removal (common/prep/table_removal.cpp, called from segment_body): the table, pad and
// cables are not body whichever side of the patient they lie on. A prone patient's table lies in
// front (on the frame's anterior side); the patient's frame does not say where gravity pointed,
// so segment_body looks for the bands from both sides.
#include <gtest/gtest.h>

#include <cstdint>

#include "io/phantom.hpp"
#include "prep/segmentation.hpp"

namespace palp {
namespace {

// The torso phantom (with its table behind the patient) at 3 x 3 x 4 mm.
CtVolume torso() {
  PhantomOptions o;
  o.dims = Index3{160, 107, 48};
  o.spacing = Vec3{3.0, 3.0, 4.0};
  return make_phantom("torso", o);
}

// Turned 180 degrees about the body axis, the direction matrix kept: the table now lies in front.
template <class T>
Volume<T> turned(const Volume<T>& v) {
  Volume<T> out(v.grid);
  const Index3& n = v.grid.dims;
  for (std::int64_t k = 0; k < n[2]; ++k)
    for (std::int64_t j = 0; j < n[1]; ++j)
      for (std::int64_t i = 0; i < n[0]; ++i) out.at(i, j, k) = v.at(n[0] - 1 - i, n[1] - 1 - j, k);
  return out;
}

TEST(TableRemoval, ATableInFrontOfAPronePatientIsRemovedToo) {
  const CtVolume supine = torso();
  SegmentationStats supine_stats, prone_stats;
  const Mask body = segment_body(supine, SegmentationParams{}, &supine_stats);
  const Mask prone_body = segment_body(turned(supine), SegmentationParams{}, &prone_stats);
  ASSERT_GT(supine_stats.table_voxels, 1000u) << "the phantom has no table to find: no test";
  EXPECT_EQ(prone_stats.table_voxels, supine_stats.table_voxels);
  const Mask back = turned(prone_body);
  std::int64_t differ = 0;
  for (std::size_t n = 0; n < body.data.size(); ++n) differ += body.data[n] != back.data[n];
  EXPECT_EQ(differ, 0);
}

}  // namespace
}  // namespace palp
