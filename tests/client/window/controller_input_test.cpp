// palpview's controller mapping (client/window/controller_input.hpp): mouse and keyboard events
// become device poses and commands with exact numbers; no window involved.
#include "window/controller_input.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

namespace palp::view {
namespace {

constexpr double kTight = 1e-12;

void expect_near(const Vec3d& a, const Vec3d& b, double tolerance = kTight) {
  EXPECT_NEAR(a.x, b.x, tolerance);
  EXPECT_NEAR(a.y, b.y, tolerance);
  EXPECT_NEAR(a.z, b.z, tolerance);
}

Pose start_pose() {
  Pose p;
  p.position = {10, 20, 30};
  return p;
}

TEST(ControllerInput, LeftDragSlidesInTheScreenPlane) {
  ControllerInput input(start_pose());
  const CameraAxes camera;                   // right +x, up +z
  EXPECT_FALSE(input.cursor(5, 5, camera));  // no button held: nothing moves
  input.button(MouseButton::Left, true, 100, 100, false);
  EXPECT_TRUE(input.dragging());
  // dx = 4, dy = -2 (up on screen): 0.25 mm a pixel -> +1 along right, +0.5 along up.
  EXPECT_TRUE(input.cursor(104, 98, camera));
  EXPECT_EQ(input.pose().position, (Vec3d{11, 20, 30.5}));
  input.button(MouseButton::Left, false, 104, 98, false);
  EXPECT_FALSE(input.cursor(200, 200, camera));
  EXPECT_EQ(input.pose().position, (Vec3d{11, 20, 30.5}));
  EXPECT_EQ(input.pose().orientation, Quat{});
  // Another camera: right = +y, up = -x.
  input.button(MouseButton::Left, true, 0, 0, false);
  input.cursor(8, 4, CameraAxes{{0, 1, 0}, {-1, 0, 0}});
  EXPECT_EQ(input.pose().position, (Vec3d{12, 22, 30.5}));
}

TEST(ControllerInput, ScrollAndKeysPressAlongTheToolAxis) {
  ControllerInput input(start_pose());
  input.scroll(2.0);  // identity: tool -z is scene -z, 1 mm a notch
  EXPECT_EQ(input.pose().position, (Vec3d{10, 20, 28}));
  input.scroll(-0.5);
  EXPECT_EQ(input.pose().position, (Vec3d{10, 20, 28.5}));
  const CameraAxes camera;
  EXPECT_TRUE(input.key(InputKey::PressIn, camera));  // 2 mm
  EXPECT_EQ(input.pose().position, (Vec3d{10, 20, 26.5}));
  EXPECT_TRUE(input.key(InputKey::PressOut, camera));
  EXPECT_TRUE(input.key(InputKey::SlideRight, camera));
  EXPECT_TRUE(input.key(InputKey::SlideUp, camera));
  EXPECT_EQ(input.pose().position, (Vec3d{12, 20, 30.5}));
  EXPECT_TRUE(input.key(InputKey::SlideLeft, camera));
  EXPECT_TRUE(input.key(InputKey::SlideDown, camera));
  EXPECT_EQ(input.pose().position, (Vec3d{10, 20, 28.5}));

  // Tool turned a quarter about x: its -z points along scene +y.
  Pose turned = start_pose();
  turned.orientation = axis_angle({1, 0, 0}, 0.5 * std::numbers::pi);
  ControllerInput pressing(turned);
  pressing.scroll(3.0);
  expect_near(pressing.pose().position, {10, 23, 30});
}

TEST(ControllerInput, KeysRotateAboutTheToolAxes) {
  const double a = 5.0 * std::numbers::pi / 180.0;
  ControllerInput input(start_pose());
  const CameraAxes camera;
  EXPECT_TRUE(input.key(InputKey::YawLeft, camera));  // +5 degrees about tool z
  expect_near(rotate(input.pose().orientation, {1, 0, 0}), {std::cos(a), std::sin(a), 0});
  EXPECT_EQ(input.pose().position, (Vec3d{10, 20, 30}));  // about the device point
  EXPECT_TRUE(input.key(InputKey::YawRight, camera));
  expect_near(rotate(input.pose().orientation, {1, 0, 0}), {1, 0, 0});

  // Tool-frame rotations compose on the right: after a quarter turn about x, a pitch about
  // the tool's x is still a rotation about scene x, and a yaw about the tool's z is a rotation
  // about scene -y.
  Pose turned = start_pose();
  turned.orientation = axis_angle({1, 0, 0}, 0.5 * std::numbers::pi);
  ControllerInput tool(turned);
  tool.key(InputKey::YawLeft, camera);
  expect_near(rotate(tool.pose().orientation, {1, 0, 0}), {std::cos(a), 0, std::sin(a)});
  tool.key(InputKey::YawRight, camera);
  tool.key(InputKey::PitchUp, camera);
  expect_near(rotate(tool.pose().orientation, {0, 0, -1}),
              {0, std::cos(a), std::sin(a)});  // press direction tilted about x
  tool.key(InputKey::PitchDown, camera);
  tool.key(InputKey::RollLeft, camera);  // about tool y = scene +z after the quarter turn
  expect_near(rotate(tool.pose().orientation, {1, 0, 0}), {std::cos(a), std::sin(a), 0});
}

TEST(ControllerInput, ShiftDragRotatesAboutTheCameraAxes) {
  ControllerInput input(start_pose());
  const CameraAxes camera;  // right +x, up +z
  input.button(MouseButton::Left, true, 0, 0, true);
  // dx = 100 pixels: 0.5 rad about the camera's up (+z).
  EXPECT_TRUE(input.cursor(100, 0, camera));
  expect_near(rotate(input.pose().orientation, {1, 0, 0}), {std::cos(0.5), std::sin(0.5), 0});
  EXPECT_EQ(input.pose().position, (Vec3d{10, 20, 30}));
  // dy = 60: 0.3 rad about the camera's right (+x), applied in the scene frame after the first.
  EXPECT_TRUE(input.cursor(100, 60, camera));
  const Vec3d x_axis = rotate(input.pose().orientation, {1, 0, 0});
  expect_near(x_axis,
              {std::cos(0.5), std::sin(0.5) * std::cos(0.3), std::sin(0.5) * std::sin(0.3)});
}

TEST(ControllerInput, ToolPauseAndResetRequests) {
  ControllerInput input(start_pose());
  const CameraAxes camera;
  EXPECT_FALSE(input.take_tool_request().has_value());
  EXPECT_FALSE(input.key(InputKey::ToolProbe, camera));
  EXPECT_EQ(input.take_tool_request(), std::optional<std::string>("probe:9x3"));
  EXPECT_FALSE(input.take_tool_request().has_value());
  input.key(InputKey::ToolTwoFinger, camera);
  input.key(InputKey::ToolFinger, camera);
  EXPECT_EQ(input.take_tool_request(), std::optional<std::string>("finger:37"));

  input.key(InputKey::Pause, camera);
  EXPECT_EQ(input.take_pause_request(), std::optional<bool>(true));
  EXPECT_FALSE(input.take_pause_request().has_value());
  input.key(InputKey::Pause, camera);
  EXPECT_EQ(input.take_pause_request(), std::optional<bool>(false));

  input.scroll(4);
  input.key(InputKey::YawLeft, camera);
  EXPECT_TRUE(input.key(InputKey::ResetPose, camera));
  EXPECT_EQ(input.pose().position, (Vec3d{10, 20, 30}));
  EXPECT_EQ(input.pose().orientation, Quat{});
}

TEST(ControllerInput, QuaternionProduct) {
  const Quat a = axis_angle({0, 0, 1}, 0.3), b = axis_angle({0, 0, 1}, 0.4);
  const Quat ab = multiply(a, b), c = axis_angle({0, 0, 1}, 0.7);
  EXPECT_NEAR(ab.w, c.w, kTight);
  EXPECT_NEAR(ab.z, c.z, kTight);
  EXPECT_EQ(multiply(Quat{}, a), a);
  // b first, then a: rotating x by (quarter about z) then (quarter about x) gives +z.
  const Quat qz = axis_angle({0, 0, 1}, 0.5 * std::numbers::pi);
  const Quat qx = axis_angle({1, 0, 0}, 0.5 * std::numbers::pi);
  expect_near(rotate(multiply(qx, qz), {1, 0, 0}), {0, 0, 1});
}

TEST(ControllerInput, InitialPoseSitsInFrontOfTheBody) {
  // 10^3 voxels of 2 mm; the body starts at j = 3 on the centre column (i = 5, k = 5).
  const std::array<std::int64_t, 3> dims{10, 10, 10};
  std::vector<float> d_surf(1000, -1.0f);
  for (std::int64_t k = 0; k < 10; ++k)
    for (std::int64_t j = 3; j < 10; ++j)
      for (std::int64_t i = 0; i < 10; ++i)
        d_surf[static_cast<std::size_t>((k * 10 + j) * 10 + i)] = 1.0f;
  const Pose pose = initial_pose(dims, {2, 2, 2}, d_surf, 20.0);
  // Pads (tool z = -8) 20 mm in front of y = 6: the device point at y = 6 - 20 - 8.
  expect_near(pose.position, {10, -22, 10});
  expect_near(rotate(pose.orientation, {0, 0, -1}), {0, 1, 0});
  // No body on the line, or a mis-sized map: the grid's front face.
  expect_near(initial_pose(dims, {2, 2, 2}, std::vector<float>(7, 1.0f), 0.0).position,
              {10, -8, 10});
}

}  // namespace
}  // namespace palp::view
