// Tests for the torso phantom's scan-placement and arm options (common/io/phantom_torso.cpp):
// `level` moves the field of view along the body (the anatomy's truth slides by whole slices), and
// with the vessel tree each arm carries its brachial artery beside the humerus, through both of
// the scan's ends. Expectations come from the drawn geometry (phantom.hpp): a 3 mm lumen 1 mm
// from an 11 mm humerus, at the arteries' HU.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <vector>

#include "base/errors.hpp"
#include "io/phantom.hpp"
#include "support/mask_metrics.hpp"
#include "support/torso_scenes.hpp"

namespace palp {
namespace {

using Drawn = testing::DrawnTorso;
using testing::torso_with;

// Voxels of `a` that `b` lacks.
Mask minus(const Mask& a, const Mask& b) {
  Mask out(a.grid, 0);
  for (std::size_t n = 0; n < a.size(); ++n) out.data[n] = a.data[n] && !b.data[n];
  return out;
}

std::int64_t count_in_slice(const Mask& m, std::int64_t k) {
  std::int64_t c = 0;
  for (std::int64_t j = 0; j < m.grid.dims[1]; ++j)
    for (std::int64_t i = 0; i < m.grid.dims[0]; ++i) c += m.at(i, j, k);
  return c;
}

// The least distance (mm) between a voxel centre of `a` and one of `b` in slice k.
double least_distance_in_slice(const Mask& a, const Mask& b, std::int64_t k) {
  std::vector<std::array<double, 2>> pa, pb;
  const Vec3& h = a.grid.spacing;
  for (std::int64_t j = 0; j < a.grid.dims[1]; ++j)
    for (std::int64_t i = 0; i < a.grid.dims[0]; ++i) {
      const std::array<double, 2> p{static_cast<double>(i) * h[0], static_cast<double>(j) * h[1]};
      if (a.at(i, j, k)) pa.push_back(p);
      if (b.at(i, j, k)) pb.push_back(p);
    }
  double least = std::numeric_limits<double>::infinity();
  for (const auto& p : pa)
    for (const auto& q : pb) least = std::min(least, std::hypot(p[0] - q[0], p[1] - q[1]));
  return least;
}

// A slab of the default grid's rows and columns (x and y unscaled), 24 slices of 2 mm.
PhantomOptions slab() {
  PhantomOptions o;
  o.dims = Index3{384, 256, 24};
  return o;
}

TEST(PhantomTorsoLevel, MovesTheFieldOfViewAlongTheBodyByWholeSlices) {
  PhantomOptions up = slab();
  up.contrast = PhantomContrast::arterial;
  PhantomOptions at_zero = up;
  up.level_mm = 6.0;  // three 2 mm slices toward the head
  const Drawn zero = torso_with(at_zero), moved = torso_with(up);
  const Grid& g = zero.ct.grid;
  const std::int64_t shift = 3, plane = g.dims[0] * g.dims[1];
  std::int64_t differs = 0, bone = 0;
  for (std::int64_t k = 0; k + shift < g.dims[2]; ++k)
    for (std::int64_t n = 0; n < plane; ++n) {
      const std::size_t a = static_cast<std::size_t>(k * plane + n),
                        b = static_cast<std::size_t>((k + shift) * plane + n);
      differs += moved.truth.bone.data[a] != zero.truth.bone.data[b];
      differs += moved.truth.vessel.data[a] != zero.truth.vessel.data[b];
      differs += moved.truth.body.data[a] != zero.truth.body.data[b];
      bone += moved.truth.bone.data[a];
    }
  EXPECT_EQ(differs, 0) << "slice k at level 6 mm is slice k + 3 at level 0";
  EXPECT_GT(bone, 0);
  // the slices the shift brings in are new anatomy, not a copy of the old top slice
  EXPECT_NE(moved.truth.bone.data, zero.truth.bone.data);
  PhantomOptions explicit_zero = at_zero;
  explicit_zero.level_mm = 0.0;
  EXPECT_TRUE(torso_with(explicit_zero).ct.data == zero.ct.data);
}

TEST(PhantomTorsoLevel, IsATorsoOptionWithinItsRange) {
  EXPECT_EQ(parse_phantom_spec("torso,level=-9").options.level_mm, -9.0);
  for (const char* bad : {"torso,level=201", "torso,level=-250", "torso,level=abc", "cube,level=5",
                          "sphere,level=1", "trunk,level=5"})
    EXPECT_THROW(parse_phantom_spec(bad), UsageError) << bad;
}

TEST(PhantomTorsoArms, WithTheVesselTreeEachArmHasItsBrachialArteryBesideTheHumerus) {
  for (int arms : {1, 2}) {
    PhantomOptions with_arms = slab(), without = slab();
    with_arms.contrast = without.contrast = PhantomContrast::arterial;
    with_arms.arms = arms;
    without.arms = 0;
    const Drawn a = torso_with(with_arms), none = torso_with(without);
    EXPECT_EQ(testing::count_and_not(none.truth.vessel, a.truth.vessel), 0)
        << "an arm covers none of the torso's vessels";
    const Mask brachial = minus(a.truth.vessel, none.truth.vessel);
    const Mask humerus = minus(a.truth.bone, none.truth.bone);
    const Grid& g = a.ct.grid;
    const double disc = std::numbers::pi * 3.0 * 3.0 / (g.spacing[0] * g.spacing[1]);  // 18.1
    for (std::int64_t k = 0; k < g.dims[2]; ++k) {
      // a cylinder along the body axis: the same lumen in every slice, both end slices included
      const std::int64_t c = count_in_slice(brachial, k);
      EXPECT_GE(c, arms * std::llround(disc * 0.7)) << "slice " << k;
      EXPECT_LE(c, arms * std::llround(disc * 1.4)) << "slice " << k;
      EXPECT_EQ(c, count_in_slice(brachial, 0)) << "slice " << k;
    }
    // 1 mm of tissue between the 3 mm lumen and the 11 mm humerus: no voxel centre of one lies
    // closer than 1 mm to one of the other, and the nearest are within two voxel diagonals of it
    const double least = least_distance_in_slice(brachial, humerus, g.dims[2] / 2);
    EXPECT_GE(least, 1.0);
    EXPECT_LE(least, 1.0 + 2.0 * std::hypot(g.spacing[0], g.spacing[1]));
    std::vector<int> hu;
    for (std::size_t n = 0; n < brachial.size(); ++n)
      if (brachial.data[n]) hu.push_back(a.ct.data[n]);
    std::sort(hu.begin(), hu.end());
    EXPECT_NEAR(hu[hu.size() / 2], 400, 12) << "the arterial phase's arteries";
  }
}

TEST(PhantomTorsoArms, WithoutTheVesselTreeTheArmHasNoContrastVessel) {
  PhantomOptions one = slab(), none = slab();
  none.arms = 0;
  EXPECT_TRUE(torso_with(one).truth.vessel.data == torso_with(none).truth.vessel.data);
}

}  // namespace
}  // namespace palp
