// The bone-beneath map (model/bone_beneath.hpp) on tiny analytic scenes: a skin face above bone
// slabs and two "ribs". Exact where the ray meets a slab face straight on, within the tracing
// tolerance on a slanted ray, the cap where the ray passes between ribs, and the nearest-bone
// lower bound outside the band.
#include "model/bone_beneath.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "base/errors.hpp"
#include "model/field_sampler.hpp"
#include "prep/maps/distance_transform.hpp"
#include "support/linear_map.hpp"

namespace palp {
namespace {

const Index3 kDims{61, 21, 41};
constexpr double kZ0 = 30.25;  // skin plane of the flat face

Grid grid() {
  Grid g;
  g.dims = kDims;
  g.spacing = {1.0, 1.0, 1.0};
  return g;
}

// D(p) = a . p + b at every voxel centre.
DistanceMap linear_map(Vec3d a, double b) {
  return test::linear_map(kDims, a, b);
}

// Bone over voxel rows z_lo..z_hi and columns x in `xs` ranges, as signed distances of the mask.
DistanceMap bone(int z_lo, int z_hi, std::initializer_list<std::pair<int, int>> xs) {
  Mask m(grid(), 0);
  for (std::int64_t k = z_lo; k <= z_hi; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (const auto& [lo, hi] : xs)
        for (std::int64_t i = lo; i <= hi; ++i) m.at(i, j, k) = 1;
  return signed_distance(m);
}

float at(const std::vector<float>& map, std::int64_t i, std::int64_t j, std::int64_t k) {
  return map[grid().linear(i, j, k)];
}

TEST(BoneBeneath, StraightDownToASlabIsExact) {
  // Slab rows 10..13: its top face at z = 13.5; the skin's inward normal is -z.
  const FieldSampler fields(linear_map({0, 0, -1}, kZ0), bone(10, 13, {{0, 60}}));
  const auto map = bone_beneath_map(fields);
  for (std::int64_t k = 14; k <= 31; ++k) EXPECT_NEAR(at(map, 30, 10, k), k - 13.5, 1e-5) << k;
  EXPECT_EQ(at(map, 30, 10, 12), 0.0f);  // inside bone
}

TEST(BoneBeneath, ASlantedRayIsTracedToTheFace) {
  // Skin tilted 45 degrees (inward normal (s, 0, -s)): the ray from height h above the slab's
  // face meets it after h * sqrt(2); tracing stops within hit_mm (0.05 mm) of the face, so the
  // length is short by at most 0.05 * sqrt(2).
  const double s = std::sqrt(0.5);
  const FieldSampler fields(linear_map({s, 0, -s}, 20.0), bone(5, 8, {{0, 60}}));
  const auto map = bone_beneath_map(fields);
  for (std::int64_t k = 12; k <= 22; ++k) {
    const double expected = (static_cast<double>(k) - 8.5) * std::sqrt(2.0);
    EXPECT_LE(at(map, 20, 10, k), expected + 1e-5) << k;
    EXPECT_GE(at(map, 20, 10, k), expected - 0.05 * std::sqrt(2.0) - 1e-5) << k;
  }
}

TEST(BoneBeneath, BetweenTwoRibsTheRayPassesToTheCap) {
  // Ribs x 18..22 and 38..42, rows 20..23. Over a rib the bone is straight beneath; midway
  // (x = 30) the nearest bone is 7.5 mm aside, but the ray goes down between the ribs and leaves
  // the grid: the map reads the cap, where the distance field alone says 7.5 mm or less.
  BoneBeneathOptions opt;
  const FieldSampler fields(linear_map({0, 0, -1}, kZ0), bone(20, 23, {{18, 22}, {38, 42}}));
  const auto map = bone_beneath_map(fields, opt);
  EXPECT_NEAR(at(map, 20, 10, 28), 28 - 23.5, 1e-5);
  EXPECT_EQ(at(map, 30, 10, 28), static_cast<float>(opt.cap_mm));
  EXPECT_LT(-fields.bone_value({30, 10, 28}), 9.0);
}

TEST(BoneBeneath, APadFeelsARibOneVoxelBesideItsEdge) {
  // Rib x 18..22, rows 20..23 (top face z = 23.5). The ray from x = 23 misses the rib, but its
  // neighbour's (x = 22) hits it: with pad_widen the voxel takes that distance, moved along the
  // plane met at the hit (0.5 mm from the rib's corner, where the field's normal tilts: within
  // 1 mm); two voxels beside the edge (x = 24) the rays miss: the cap. Without it, x = 23 reads
  // the cap, and between x = 22 and 23 the tick would read the average of a hit and a miss.
  BoneBeneathOptions opt;
  const FieldSampler fields(linear_map({0, 0, -1}, kZ0), bone(20, 23, {{18, 22}}));
  const auto map = bone_beneath_map(fields, opt);
  EXPECT_GE(at(map, 23, 10, 28), 28 - 23.5 - 1e-5);
  EXPECT_LE(at(map, 23, 10, 28), 28 - 23.5 + 1.0);
  EXPECT_EQ(at(map, 24, 10, 28), static_cast<float>(opt.cap_mm));
  opt.pad_widen = false;
  const auto narrow = bone_beneath_map(fields, opt);
  EXPECT_EQ(at(narrow, 23, 10, 28), static_cast<float>(opt.cap_mm));
  EXPECT_NEAR(at(narrow, 22, 10, 28), 28 - 23.5, 1e-5);
}

TEST(BoneBeneath, OutsideTheBandTheNearestBoneIsALowerBound) {
  BoneBeneathOptions opt;
  opt.band_mm = 3.0;  // voxel rows z >= 28 (skin depth <= 2.25) are traced
  const FieldSampler fields(linear_map({0, 0, -1}, kZ0), bone(20, 23, {{18, 22}, {38, 42}}));
  const auto map = bone_beneath_map(fields, opt);
  EXPECT_EQ(at(map, 30, 10, 28), static_cast<float>(opt.cap_mm));            // in the band: traced
  EXPECT_NEAR(at(map, 30, 10, 26), -fields.bone_value({30, 10, 26}), 1e-5);  // depth 4.25
  EXPECT_LT(at(map, 30, 10, 26), 9.0f);
}

TEST(BoneBeneath, NeedsABoneMapAndIsPreparedOnce) {
  const FieldSampler no_bone(linear_map({0, 0, -1}, kZ0));
  EXPECT_THROW(bone_beneath_map(no_bone), UsageError);
  no_bone.prepare_bone_beneath();  // no-op without bone
  EXPECT_FALSE(no_bone.has_bone_beneath());

  const FieldSampler fields(linear_map({0, 0, -1}, kZ0), bone(10, 13, {{0, 60}}));
  EXPECT_FALSE(fields.has_bone_beneath());
  fields.prepare_bone_beneath();
  const float* first = fields.bone_beneath_data();
  ASSERT_NE(first, nullptr);
  fields.prepare_bone_beneath();
  EXPECT_EQ(fields.bone_beneath_data(), first);
  EXPECT_NEAR(first[grid().linear(30, 10, 20)], 20 - 13.5, 1e-5);
}

}  // namespace
}  // namespace palp
