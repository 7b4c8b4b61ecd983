// Patient directions from direction matrices: exact vectors for axis-aligned storages, the
// obliquity of a tilted one, and the identity for a matrix that is not a rotation.
#include "base/patient_frame.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace palp {
namespace {

// Row-major direction with columns ci, cj, ck (LPS).
WorldPlacement placement(Vec3d ci, Vec3d cj, Vec3d ck) {
  WorldPlacement w;
  w.direction = {ci.x, cj.x, ck.x, ci.y, cj.y, ck.y, ci.z, cj.z, ck.z};
  return w;
}

constexpr Vec3d L{1, 0, 0}, P{0, 1, 0}, S{0, 0, 1};

TEST(PatientFrame, IdentityIsLps) {
  const PatientFrame f = patient_frame(WorldPlacement{});
  EXPECT_EQ(f.orientation_code(), "LPS");
  EXPECT_EQ(f.toward(Anatomy::Anterior), (Vec3d{0, -1, 0}));
  EXPECT_EQ(f.nearest_axis(Anatomy::Anterior), (SignedAxis{1, -1}));
  EXPECT_EQ(f.nearest_axis(Anatomy::Superior), (SignedAxis{2, 1}));
  EXPECT_EQ(to_string(f.nearest_axis(Anatomy::Anterior)), "-y");
  EXPECT_EQ(f.obliquity_deg(), 0.0);
}

TEST(PatientFrame, RasStorageFacesTheOtherWay) {
  // i toward the right, j toward anterior, k toward superior: NIfTI's canonical order.
  const PatientFrame f = patient_frame(placement(-L, -P, S));
  EXPECT_EQ(f.orientation_code(), "RAS");
  EXPECT_EQ(f.toward(Anatomy::Anterior), (Vec3d{0, 1, 0}));
  EXPECT_EQ(f.toward(Anatomy::Left), (Vec3d{-1, 0, 0}));
  EXPECT_EQ(f.nearest_axis(Anatomy::Anterior), (SignedAxis{1, 1}));
}

TEST(PatientFrame, PermutedAxesAndReversedSlices) {
  // i toward inferior, j toward left, k toward anterior (the cube phantom's order).
  const PatientFrame f = patient_frame(placement(-S, L, -P));
  EXPECT_EQ(f.orientation_code(), "ILA");
  EXPECT_EQ(f.nearest_axis(Anatomy::Anterior), (SignedAxis{2, 1}));
  EXPECT_EQ(f.nearest_axis(Anatomy::Left), (SignedAxis{1, 1}));
  EXPECT_EQ(f.nearest_axis(Anatomy::Superior), (SignedAxis{0, -1}));
  // Slices stored superior to inferior.
  const PatientFrame g = patient_frame(placement(L, P, -S));
  EXPECT_EQ(g.orientation_code(), "LPI");
  EXPECT_EQ(g.toward(Anatomy::Superior), (Vec3d{0, 0, -1}));
}

TEST(PatientFrame, TiltIsMeasured) {
  const double a = 20.0 * 3.14159265358979323846 / 180.0;  // a gantry tilt about left-right
  const PatientFrame f =
      patient_frame(placement(L, {0, std::cos(a), std::sin(a)}, {0, -std::sin(a), std::cos(a)}));
  EXPECT_NEAR(f.obliquity_deg(), 20.0, 1e-9);
  EXPECT_EQ(f.orientation_code(), "LPS");
  EXPECT_NEAR(f.toward(Anatomy::Superior).y, std::sin(a), 1e-15);  // row 2 of D
}

TEST(PatientFrame, NotARotationMeansNoDirection) {
  WorldPlacement w;
  w.direction = {2, 0, 0, 0, 1, 0, 0, 0, 1};
  EXPECT_EQ(patient_frame(w).orientation_code(), "LPS");
  w.direction = {1, 0, 0, 0, 0, 0, 0, 0, 1};
  EXPECT_EQ(patient_frame(w).orientation_code(), "LPS");
  w.direction[0] = std::nan("");
  EXPECT_EQ(patient_frame(w).toward(Anatomy::Anterior), (Vec3d{0, -1, 0}));
}

TEST(PatientFrame, ParsesNamesAndLetters) {
  Anatomy a{};
  EXPECT_TRUE(parse_anatomy("anterior", &a));
  EXPECT_EQ(a, Anatomy::Anterior);
  EXPECT_TRUE(parse_anatomy("L", &a));
  EXPECT_EQ(a, Anatomy::Left);
  EXPECT_FALSE(parse_anatomy("front", &a));
  EXPECT_FALSE(parse_anatomy("", &a));
  EXPECT_EQ(opposite(Anatomy::Superior), Anatomy::Inferior);
}

// Scene <-> world through a rotated, offset placement: scene (10, 20, 30) with i along -S, j
// along +L and k along -P from the origin (3, -4, 5) is, summed by hand,
// (3 + 20, -4 - 30, 5 - 10) = (23, -34, -5); and back.
TEST(PatientFrame, SceneAndWorldThroughARotatedPlacement) {
  Grid grid;
  grid.world = placement(-1.0 * S, L, -1.0 * P);
  grid.world.origin = {3, -4, 5};
  const Vec3d world = world_of_scene(grid, {10, 20, 30});
  EXPECT_NEAR(world.x, 23.0, 1e-12);
  EXPECT_NEAR(world.y, -34.0, 1e-12);
  EXPECT_NEAR(world.z, -5.0, 1e-12);
  const Vec3d back = scene_of_world(grid, world);
  EXPECT_NEAR(back.x, 10.0, 1e-12);
  EXPECT_NEAR(back.y, 20.0, 1e-12);
  EXPECT_NEAR(back.z, 30.0, 1e-12);
}

}  // namespace
}  // namespace palp
