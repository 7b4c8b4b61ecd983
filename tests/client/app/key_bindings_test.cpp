// palpview's key bindings without a window: every key of the usage text does what it says, no
// key is both the view's and the controller's, and unbound keys do nothing.
#include "app/key_bindings.hpp"

#include <GLFW/glfw3.h>
#include <gtest/gtest.h>

namespace palp::view {
namespace {

TEST(KeyBindings, ViewKeys) {
  EXPECT_EQ(view_key(GLFW_KEY_ESCAPE), ViewKey::Close);
  EXPECT_EQ(view_key(GLFW_KEY_P), ViewKey::NextPreset);
  EXPECT_EQ(view_key(GLFW_KEY_LEFT_BRACKET), ViewKey::LevelDown);
  EXPECT_EQ(view_key(GLFW_KEY_RIGHT_BRACKET), ViewKey::LevelUp);
  EXPECT_EQ(view_key(GLFW_KEY_MINUS), ViewKey::Narrower);
  EXPECT_EQ(view_key(GLFW_KEY_EQUAL), ViewKey::Wider);
  EXPECT_EQ(view_key(GLFW_KEY_HOME), ViewKey::ResetCamera);
  EXPECT_EQ(view_key(GLFW_KEY_H), ViewKey::Recentre);
  EXPECT_EQ(view_key(GLFW_KEY_O), ViewKey::ToggleRecording);
  EXPECT_EQ(view_key(GLFW_KEY_V), ViewKey::NextView);
  EXPECT_EQ(view_key(GLFW_KEY_COMMA), ViewKey::PulseSlower);
  EXPECT_EQ(view_key(GLFW_KEY_PERIOD), ViewKey::PulseFaster);
  EXPECT_EQ(view_key(GLFW_KEY_B), ViewKey::PulseToggle);
  EXPECT_FALSE(view_key(GLFW_KEY_W));
  EXPECT_FALSE(view_key(GLFW_KEY_X));
}

TEST(KeyBindings, ControllerKeys) {
  EXPECT_EQ(controller_key(GLFW_KEY_LEFT), InputKey::SlideLeft);
  EXPECT_EQ(controller_key(GLFW_KEY_RIGHT), InputKey::SlideRight);
  EXPECT_EQ(controller_key(GLFW_KEY_UP), InputKey::SlideUp);
  EXPECT_EQ(controller_key(GLFW_KEY_DOWN), InputKey::SlideDown);
  EXPECT_EQ(controller_key(GLFW_KEY_W), InputKey::PressIn);
  EXPECT_EQ(controller_key(GLFW_KEY_S), InputKey::PressOut);
  EXPECT_EQ(controller_key(GLFW_KEY_Q), InputKey::YawLeft);
  EXPECT_EQ(controller_key(GLFW_KEY_E), InputKey::YawRight);
  EXPECT_EQ(controller_key(GLFW_KEY_R), InputKey::PitchUp);
  EXPECT_EQ(controller_key(GLFW_KEY_F), InputKey::PitchDown);
  EXPECT_EQ(controller_key(GLFW_KEY_Z), InputKey::RollLeft);
  EXPECT_EQ(controller_key(GLFW_KEY_C), InputKey::RollRight);
  EXPECT_EQ(controller_key(GLFW_KEY_1), InputKey::ToolFinger);
  EXPECT_EQ(controller_key(GLFW_KEY_2), InputKey::ToolTwoFinger);
  EXPECT_EQ(controller_key(GLFW_KEY_3), InputKey::ToolProbe);
  EXPECT_EQ(controller_key(GLFW_KEY_SPACE), InputKey::Pause);
  EXPECT_EQ(controller_key(GLFW_KEY_BACKSPACE), InputKey::ResetPose);
  EXPECT_FALSE(controller_key(GLFW_KEY_X));
}

TEST(KeyBindings, NoKeyIsBoth) {
  for (int key = GLFW_KEY_SPACE; key <= GLFW_KEY_LAST; ++key)
    EXPECT_FALSE(view_key(key) && controller_key(key)) << "key " << key;
}

}  // namespace
}  // namespace palp::view
