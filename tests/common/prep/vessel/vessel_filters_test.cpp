// Tests for the vessel search's filters (common/prep/vessel/vessel_filters.cpp) on scenes built
// here: the 3x3x3 mean against a plain three-pass definition and on flat and ramped volumes,
// and the ridge test on a one-voxel plate, a step and a thick block, whose directions follow from
// the geometry (13 directions; those with a component across the plate cross it).
#include "prep/vessel/vessel_filters.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace palp {
namespace {

CtVolume volume(Index3 dims, std::int16_t hu) {
  Grid g;
  g.dims = dims;
  g.spacing = {1.0, 1.0, 1.0};
  return CtVolume(g, hu, "ct");
}

// The mean of three, rounded half away from zero, along one axis with the border repeated: the
// definition the filter states, written plainly (three passes, no buffers reused).
std::vector<std::int16_t> mean_along(const std::vector<std::int16_t>& in, const Index3& n,
                                     int axis) {
  std::vector<std::int16_t> out(in.size());
  const std::int64_t stride[3] = {1, n[0], n[0] * n[1]};
  for (std::int64_t k = 0; k < n[2]; ++k)
    for (std::int64_t j = 0; j < n[1]; ++j)
      for (std::int64_t i = 0; i < n[0]; ++i) {
        const std::int64_t at[3] = {i, j, k};
        const std::int64_t c = i + n[0] * (j + n[1] * k);
        const std::int64_t lo = at[axis] > 0 ? c - stride[axis] : c;
        const std::int64_t hi = at[axis] + 1 < n[axis] ? c + stride[axis] : c;
        const int sum = in[lo] + in[c] + in[hi];
        out[c] = static_cast<std::int16_t>(sum >= 0 ? (sum + 1) / 3 : -((-sum + 1) / 3));
      }
  return out;
}

TEST(SmoothedHu, IsThreeMeansOfThreeAlongEachAxis) {
  CtVolume ct = volume({17, 13, 11}, 0);
  for (std::size_t n = 0; n < ct.size(); ++n)
    ct.data[n] = static_cast<std::int16_t>(static_cast<int>((n * 7919 + 13) % 2001) - 1000);
  const Index3 d = ct.grid.dims;
  EXPECT_EQ(smoothed_hu(ct), mean_along(mean_along(mean_along(ct.data, d, 0), d, 1), d, 2));
}

TEST(SmoothedHu, KeepsAFlatVolumeAndALinearRampInside) {
  const CtVolume flat = volume({9, 8, 7}, -37);
  EXPECT_EQ(smoothed_hu(flat), flat.data);
  CtVolume ramp = volume({12, 6, 6}, 0);
  for (std::int64_t k = 0; k < 6; ++k)
    for (std::int64_t j = 0; j < 6; ++j)
      for (std::int64_t i = 0; i < 12; ++i) ramp.at(i, j, k) = static_cast<std::int16_t>(30 * i);
  const std::vector<std::int16_t> s = smoothed_hu(ramp);
  for (std::int64_t i = 1; i + 1 < 12; ++i) EXPECT_EQ(s[ramp.grid.linear(i, 3, 3)], 30 * i);
  EXPECT_EQ(s[ramp.grid.linear(0, 3, 3)], 10) << "(0 + 0 + 30) / 3: the border repeated";
}

TEST(RidgeCortex, AOneVoxelPlateIsARidgeAlongTheNineDirectionsThatCrossIt) {
  CtVolume ct = volume({11, 11, 11}, 40);
  for (std::int64_t j = 0; j < 11; ++j)
    for (std::int64_t i = 0; i < 11; ++i) ct.at(i, j, 5) = 900;
  const Mask ridge = ridge_cortex(ct, 300.0, 40.0, 0.35);
  EXPECT_EQ(ridge.at(5, 5, 5), 9);
  EXPECT_EQ(ridge.at(0, 0, 5), 9) << "at the scan's corner too, its border repeated";
  EXPECT_EQ(ridge.at(5, 5, 4), 0) << "soft tissue is below the level";
}

TEST(RidgeCortex, AStepAndAThickBlockAreNoRidge) {
  CtVolume step = volume({11, 11, 11}, 40);
  for (std::int64_t k = 5; k < 11; ++k)
    for (std::int64_t j = 0; j < 11; ++j)
      for (std::int64_t i = 0; i < 11; ++i) step.at(i, j, k) = 900;
  for (std::uint8_t v : ridge_cortex(step, 300.0, 40.0, 0.35).data) EXPECT_EQ(v, 0);
  // A block five voxels thick: its middle is bright along every ray; its surface voxels are
  // bright two voxels deep into it along half the rays or more, so no voxel of it is a ridge.
  CtVolume block = volume({15, 15, 15}, 40);
  for (std::int64_t k = 5; k < 10; ++k)
    for (std::int64_t j = 5; j < 10; ++j)
      for (std::int64_t i = 5; i < 10; ++i) block.at(i, j, k) = 900;
  const Mask ridge = ridge_cortex(block, 300.0, 40.0, 0.35);
  EXPECT_EQ(ridge.at(7, 7, 7), 0);
  EXPECT_EQ(ridge.at(7, 7, 5), 0);
  // A plate two voxels thick is still a shell: a ridge across it (the means one and two voxels
  // away on each side mix the plate and the soft tissue below the drop).
  CtVolume plate2 = volume({11, 11, 11}, 40);
  for (std::int64_t k = 5; k <= 6; ++k)
    for (std::int64_t j = 0; j < 11; ++j)
      for (std::int64_t i = 0; i < 11; ++i) plate2.at(i, j, k) = 900;
  EXPECT_GT(ridge_cortex(plate2, 300.0, 40.0, 0.35).at(5, 5, 5), 0);
}

}  // namespace
}  // namespace palp
