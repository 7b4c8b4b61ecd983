// Scene poses and vectors in the CT's RAS patient frame (server/interop/igtl_frame.cpp): exact
// numbers for grids stored LPS, RAS and with permuted axes.
#include "interop/igtl_frame.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace palp::interop {
namespace {

Grid grid_with(std::array<double, 9> direction, Vec3 origin) {
  Grid g;
  g.dims = {10, 20, 30};
  g.spacing = {2.0, 3.0, 4.0};
  g.world.direction = direction;
  g.world.origin = origin;
  return g;
}

void expect_matrix(const Matrix4& m, const Matrix4& want) {
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(m[r][c], want[r][c], 1e-12) << r << "," << c;
}

TEST(IgtlFrame, LpsStorageNegatesXAndY) {
  // Identity direction (stored LPS), origin (10, 20, 30) LPS: the scene point (1, 2, 3) is LPS
  // (11, 22, 33), RAS (-11, -22, 33).
  const Matrix4 m = ras_from_scene(grid_with({1, 0, 0, 0, 1, 0, 0, 0, 1}, {10, 20, 30}));
  expect_matrix(m, {{{-1, 0, 0, -10}, {0, -1, 0, -20}, {0, 0, 1, 30}, {0, 0, 0, 1}}});
  Pose p;
  p.position = {1, 2, 3};
  const Matrix4 t = ras_pose(m, p);
  expect_matrix(t, {{{-1, 0, 0, -11}, {0, -1, 0, -22}, {0, 0, 1, 33}, {0, 0, 0, 1}}});
}

TEST(IgtlFrame, RasStorageIsTheIdentityRotation) {
  // Stored RAS: i points to the patient's right (-x LPS), j to anterior (-y LPS):
  // D = diag(-1, -1, 1), and the scene axes are the RAS axes.
  const Matrix4 m = ras_from_scene(grid_with({-1, 0, 0, 0, -1, 0, 0, 0, 1}, {100, 50, -7}));
  expect_matrix(m, {{{1, 0, 0, -100}, {0, 1, 0, -50}, {0, 0, 1, -7}, {0, 0, 0, 1}}});
  const Vec3d f = ras_vector(m, {0.5, -1.5, 2.0});  // a vector ignores the origin
  EXPECT_EQ(f.x, 0.5);
  EXPECT_EQ(f.y, -1.5);
  EXPECT_EQ(f.z, 2.0);
}

TEST(IgtlFrame, PermutedAxesAndAToolRotation) {
  // Stored SLP: i toward superior (+z LPS), j toward left (+x), k toward posterior (+y).
  // Columns of D: (0,0,1), (1,0,0), (0,1,0).
  const Matrix4 m = ras_from_scene(grid_with({0, 1, 0, 0, 0, 1, 1, 0, 0}, {0, 0, 0}));
  // Tool turned 90 degrees about the scene's z (k, posterior): tool x -> scene y.
  Pose p;
  p.position = {4, 5, 6};  // LPS (5, 6, 4) -> RAS (-5, -6, 4)
  p.orientation = {std::sqrt(0.5), 0, 0, std::sqrt(0.5)};
  const Matrix4 t = ras_pose(m, p);
  // Tool x -> scene +y (j, left) -> RAS -x; tool y -> scene -x (i, superior) -> RAS -z;
  // tool z -> scene +z (k, posterior) -> RAS -y.
  expect_matrix(t, {{{-1, 0, 0, -5}, {0, 0, -1, -6}, {0, -1, 0, 4}, {0, 0, 0, 1}}});
}

TEST(IgtlFrame, ReversedSlicesGiveAMirroringTransform) {
  // Stored LPI (k toward inferior): the scene frame is mirrored against the patient, so the
  // tool -> RAS map is too (determinant -1): it still puts every tool point where palp has it.
  const Matrix4 m = ras_from_scene(grid_with({1, 0, 0, 0, 1, 0, 0, 0, -1}, {0, 0, 0}));
  const Matrix4 t = ras_pose(m, Pose{});
  const double det = t[0][0] * (t[1][1] * t[2][2] - t[1][2] * t[2][1]) -
                     t[0][1] * (t[1][0] * t[2][2] - t[1][2] * t[2][0]) +
                     t[0][2] * (t[1][0] * t[2][1] - t[1][1] * t[2][0]);
  EXPECT_NEAR(det, -1.0, 1e-12);
}

}  // namespace
}  // namespace palp::interop
