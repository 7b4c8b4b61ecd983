// Reordering axes keeps every voxel where it was in the world; an oblique grid is resampled onto
// the nearest axis-aligned frame with the patient in the same place; unusable cases are refused.
#include "prep/reorient.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "base/vec.hpp"

namespace palp {
namespace {

Vec3d world(const Grid& g, double i, double j, double k) {
  return world_of_scene(g, {i * g.spacing[0], j * g.spacing[1], k * g.spacing[2]});
}

// 4 x 3 x 2 voxels of 1 x 2 x 3 mm, value 100 i + 10 j + k, stored LPS.
CtVolume small() {
  Grid g;
  g.dims = {4, 3, 2};
  g.spacing = {1, 2, 3};
  g.world.origin = {10, 20, 30};
  CtVolume v(g);
  for (std::int64_t k = 0; k < 2; ++k)
    for (std::int64_t j = 0; j < 3; ++j)
      for (std::int64_t i = 0; i < 4; ++i)
        v.at(i, j, k) = static_cast<std::int16_t>(100 * i + 10 * j + k);
  return v;
}

TEST(Reorient, ReorderKeepsEveryVoxelInPlace) {
  const CtVolume v = small();
  for (const char* code : {"RAS", "LPI", "SLP", "AIR", "LPS"}) {
    SCOPED_TRACE(code);
    const CtVolume r = reorder_axes(v, code);
    EXPECT_EQ(patient_frame(r.grid).orientation_code(), code);
    EXPECT_EQ(r.grid.voxel_count(), v.grid.voxel_count());
    for (std::int64_t k = 0; k < r.grid.dims[2]; ++k)
      for (std::int64_t j = 0; j < r.grid.dims[1]; ++j)
        for (std::int64_t i = 0; i < r.grid.dims[0]; ++i) {
          const std::int16_t value = r.at(i, j, k);
          const Vec3d w =
              world(r.grid, static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
          const Vec3d expected = world(v.grid, value / 100, (value / 10) % 10, value % 10);
          ASSERT_LT(norm(w - expected), 1e-9) << i << " " << j << " " << k;
        }
    const CtVolume back = reorder_axes(r, "LPS");
    EXPECT_EQ(back.grid, v.grid);
    EXPECT_EQ(back.data, v.data);
  }
}

TEST(Reorient, BadCodesAreRefused) {
  const CtVolume v = small();
  EXPECT_THROW(reorder_axes(v, "LLS"), UsageError);
  EXPECT_THROW(reorder_axes(v, "LRS"), UsageError);
  EXPECT_THROW(reorder_axes(v, "LP"), UsageError);
  EXPECT_THROW(reorder_axes(v, "XYZ"), UsageError);
}

TEST(Reorient, AxisAlignedGridOfAnAlignedGridIsItself) {
  const CtVolume v = reorder_axes(small(), "RAS");
  EXPECT_EQ(axis_aligned_grid(v.grid), v.grid);
  const CtVolume r = resample_axis_aligned(v);
  EXPECT_EQ(r.data, v.data);
}

TEST(Reorient, TiltedGridBecomesAlignedAroundTheSameVoxels) {
  Grid g;
  g.dims = {20, 20, 10};
  g.spacing = {1, 1, 2};
  const double t = 10.0 * 3.14159265358979323846 / 180.0;
  g.world.direction = {1, 0, 0, 0, std::cos(t), -std::sin(t), 0, std::sin(t), std::cos(t)};
  CtVolume v(g, std::int16_t{40});
  const Grid a = axis_aligned_grid(g);
  EXPECT_EQ(patient_frame(a).obliquity_deg(), 0.0);
  EXPECT_EQ(a.spacing, g.spacing);
  // The box holds the rotated voxel centres: 19 x (19 cos t + 18 sin t) x (18 cos t + 19 sin t)
  // mm, rounded outward to whole voxels at both ends.
  EXPECT_EQ(a.dims[0], 20);
  const double along_p = 19 * std::cos(t) + 18 * std::sin(t);
  EXPECT_GE(a.dims[1], static_cast<std::int64_t>(std::ceil(along_p)) + 1);
  EXPECT_LE(a.dims[1], static_cast<std::int64_t>(std::ceil(along_p)) + 2);
  const CtVolume r = resample_axis_aligned(v);
  // Inside the old volume: its value; outside (the wedges): air.
  std::int64_t tissue = 0, air = 0;
  for (std::int16_t x : r.data) {
    if (x == 40) ++tissue;
    if (x == -1000) ++air;
  }
  EXPECT_GT(tissue, 0);
  EXPECT_GT(air, 0);
  // Tissue fills the hull of the old voxel centres (19 x 19 x 18 mm), within 10% (the voxels
  // on its rotated faces are in or out whole).
  const double mm3 = static_cast<double>(tissue) * a.spacing[0] * a.spacing[1] * a.spacing[2];
  EXPECT_NEAR(mm3, 19.0 * 19.0 * 18.0, 0.1 * 19.0 * 19.0 * 18.0);
}

TEST(Reorient, FortyFiveDegreesHasNoNearestFrame) {
  Grid g;
  g.dims = {4, 4, 4};
  const double c = std::sqrt(0.5);
  g.world.direction = {c, -c, 0, c, c, 0, 0, 0, 1};
  EXPECT_THROW(axis_aligned_grid(g), InputError);
}

}  // namespace
}  // namespace palp
