// Vector and quaternion helpers of the force loop.
#include "base/vec.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace palp {
namespace {

TEST(Vec, Arithmetic) {
  const Vec3d a{1, 2, 3}, b{-4, 5, 0.5};
  EXPECT_EQ(a + b, (Vec3d{-3, 7, 3.5}));
  EXPECT_EQ(a - b, (Vec3d{5, -3, 2.5}));
  EXPECT_EQ(2.0 * a, (Vec3d{2, 4, 6}));
  EXPECT_EQ(-a, (Vec3d{-1, -2, -3}));
  EXPECT_DOUBLE_EQ(dot(a, b), -4 + 10 + 1.5);
  EXPECT_EQ(cross(Vec3d{1, 0, 0}, Vec3d{0, 1, 0}), (Vec3d{0, 0, 1}));
  EXPECT_DOUBLE_EQ(norm(Vec3d{3, 4, 12}), 13.0);
  EXPECT_TRUE(is_finite(a));
  EXPECT_FALSE(is_finite(Vec3d{0, std::nan(""), 0}));
  EXPECT_EQ(to_vec3d(to_vec3(a)), a);
}

TEST(Quat, RotatesLikeAxisAngle) {
  const Quat qz = axis_angle({0, 0, 1}, std::numbers::pi / 2);
  const Vec3d r = rotate(qz, {1, 0, 0});
  EXPECT_NEAR(r.x, 0.0, 1e-15);
  EXPECT_NEAR(r.y, 1.0, 1e-15);
  EXPECT_NEAR(r.z, 0.0, 1e-15);
  const Quat qy = axis_angle({0, 1, 0}, 0.3);
  const Vec3d v = rotate(qy, {1, 0, 0});
  EXPECT_NEAR(v.x, std::cos(0.3), 1e-15);
  EXPECT_NEAR(v.z, -std::sin(0.3), 1e-15);
  EXPECT_EQ(rotate(Quat{}, Vec3d{1, 2, 3}), (Vec3d{1, 2, 3}));
}

TEST(Quat, PreservesLengthAndNormalises) {
  std::mt19937 rng(4);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int i = 0; i < 100; ++i) {
    const Quat q = normalized(Quat{g(rng), g(rng), g(rng), g(rng)});
    EXPECT_NEAR(norm(q), 1.0, 1e-12);
    const Vec3d v{g(rng), g(rng), g(rng)};
    EXPECT_NEAR(norm(rotate(q, v)), norm(v), 1e-12);
  }
  const Quat zero = normalized(Quat{0, 0, 0, 0});
  EXPECT_TRUE(std::isnan(zero.w));
}

}  // namespace
}  // namespace palp
