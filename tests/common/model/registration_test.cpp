// The device-to-scene registration: exact mappings for a patient-axes rotation, the transposed
// force, torque scaling, mirrored storage, and the reach check's answer.
#include "model/registration.hpp"

#include <gtest/gtest.h>

#include "base/errors.hpp"

namespace palp {
namespace {

// The torso's frame (LPS storage): scene x = left, y = posterior, z = superior.
const PatientFrame kLps{};

TEST(Registration, AxesNameWhereTheDeviceAxesPoint) {
  // IAR: device x -> inferior (-z), y -> anterior (-y), z -> right (-x).
  const auto r = rotation_from_axes(kLps, "IAR");
  EXPECT_EQ(r, (std::array<double, 9>{0, 0, -1, 0, -1, 0, -1, 0, 0}));
  EXPECT_THROW(rotation_from_axes(kLps, "IAP"), UsageError);
  EXPECT_THROW(rotation_from_axes(kLps, "IA"), UsageError);
  EXPECT_THROW(rotation_from_axes(kLps, "XYZ"), UsageError);
}

TEST(Registration, PosesAndForcesMapExactly) {
  Registration r;
  r.rotation = rotation_from_axes(kLps, "SAL");  // x superior, y anterior, z left: det +1
  r.scale = 2.0;
  r.home = {100, 50, 80};
  Pose device;
  device.position = {1, 2, 3};
  const Pose scene = to_scene(r, device);
  // R (1, 2, 3) = 1 superior + 2 anterior + 3 left = (3, -2, 1); scaled by 2, moved to home.
  EXPECT_EQ(scene.position, (Vec3d{106, 46, 82}));
  EXPECT_EQ(scene_point_to_device(r, scene.position), device.position);
  // The tool turns with the device: device +z (left) is scene +x.
  const Vec3d z = rotate(scene.orientation, {0, 0, 1});
  EXPECT_NEAR(z.x, 1.0, 1e-15);
  EXPECT_NEAR(z.y, 0.0, 1e-15);
  EXPECT_NEAR(z.z, 0.0, 1e-15);
  // A force pushing the finger out toward anterior (-y) is +y on the device.
  EXPECT_EQ(force_to_device(r, {0, -4, 0}), (Vec3d{0, 4, 0}));
  EXPECT_EQ(force_to_scene(r, force_to_device(r, {1, -2, 3})), (Vec3d{1, -2, 3}));
  // Torques: moment arms are `scale` times longer in the scene.
  EXPECT_EQ(torque_to_device(r, {0, 0, 10}), (Vec3d{5, 0, 0}));
}

TEST(Registration, MirroredStorageMirrorsTheDevice) {
  // A CT stored with i toward the right but j posterior, k superior (RPS: mirrored).
  PatientFrame f;
  f.left = {-1, 0, 0};
  const Registration r{rotation_from_axes(f, "IAR"), 1.0, {}};
  Pose device;
  device.position = {0, 0, 10};  // toward the user: the patient's right
  EXPECT_EQ(to_scene(r, device).position, (Vec3d{10, 0, 0}));   // +x is the right here
  EXPECT_EQ(torque_to_device(r, {0, 0, 1}), (Vec3d{1, 0, 0}));  // det -1: the sign flips
}

TEST(Registration, IdentityIsRecognised) {
  EXPECT_TRUE(Registration{}.is_identity());
  Registration r;
  r.scale = 1.5;
  EXPECT_FALSE(r.is_identity());
}

TEST(Registration, ReachCheckSaysWhatIsMissing) {
  Registration r;
  r.rotation = rotation_from_axes(kLps, "IAR");
  const Vec3d skin{0, 0, 0}, normal{0, -1, 0};  // anterior skin, normal toward anterior
  r.home = skin + normal * 20.0;                // 20 mm above it
  // 10 mm below the skin is 30 mm below home: device y = -30.
  EXPECT_TRUE(check_reach(r, skin, normal, {50, 50, 50}, 10.0).empty());
  const std::string message = check_reach(r, skin, normal, {50, 25, 50}, 10.0);
  EXPECT_NE(message.find("0.0, -30.0, "), std::string::npos) << message;
  EXPECT_NE(message.find("workspace is ±(50, 25, 50) mm"), std::string::npos) << message;
  r.scale = 2.0;  // the same point is 15 device mm away
  EXPECT_TRUE(check_reach(r, skin, normal, {50, 25, 50}, 10.0).empty());
}

}  // namespace
}  // namespace palp
