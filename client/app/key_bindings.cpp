// palpview's key bindings (see the header).
#include "app/key_bindings.hpp"

#include <GLFW/glfw3.h>

#include <utility>

namespace palp::view {

std::optional<ViewKey> view_key(int glfw_key) {
  static constexpr std::pair<int, ViewKey> kKeys[] = {
      {GLFW_KEY_ESCAPE, ViewKey::Close},           {GLFW_KEY_P, ViewKey::NextPreset},
      {GLFW_KEY_LEFT_BRACKET, ViewKey::LevelDown}, {GLFW_KEY_RIGHT_BRACKET, ViewKey::LevelUp},
      {GLFW_KEY_MINUS, ViewKey::Narrower},         {GLFW_KEY_EQUAL, ViewKey::Wider},
      {GLFW_KEY_HOME, ViewKey::ResetCamera},       {GLFW_KEY_H, ViewKey::Recentre},
      {GLFW_KEY_O, ViewKey::ToggleRecording},      {GLFW_KEY_V, ViewKey::NextView},
      {GLFW_KEY_COMMA, ViewKey::PulseSlower},      {GLFW_KEY_PERIOD, ViewKey::PulseFaster},
      {GLFW_KEY_B, ViewKey::PulseToggle},          {GLFW_KEY_M, ViewKey::TaskMark},
      {GLFW_KEY_L, ViewKey::ToggleLandmarks}};
  for (const auto& [key, action] : kKeys)
    if (key == glfw_key) return action;
  return std::nullopt;
}

std::optional<InputKey> controller_key(int glfw_key) {
  static constexpr std::pair<int, InputKey> kKeys[] = {
      {GLFW_KEY_LEFT, InputKey::SlideLeft},     {GLFW_KEY_RIGHT, InputKey::SlideRight},
      {GLFW_KEY_UP, InputKey::SlideUp},         {GLFW_KEY_DOWN, InputKey::SlideDown},
      {GLFW_KEY_W, InputKey::PressIn},          {GLFW_KEY_S, InputKey::PressOut},
      {GLFW_KEY_Q, InputKey::YawLeft},          {GLFW_KEY_E, InputKey::YawRight},
      {GLFW_KEY_R, InputKey::PitchUp},          {GLFW_KEY_F, InputKey::PitchDown},
      {GLFW_KEY_Z, InputKey::RollLeft},         {GLFW_KEY_C, InputKey::RollRight},
      {GLFW_KEY_1, InputKey::ToolFinger},       {GLFW_KEY_2, InputKey::ToolTwoFinger},
      {GLFW_KEY_3, InputKey::ToolProbe},        {GLFW_KEY_SPACE, InputKey::Pause},
      {GLFW_KEY_BACKSPACE, InputKey::ResetPose}};
  for (const auto& [key, input] : kKeys)
    if (key == glfw_key) return input;
  return std::nullopt;
}

}  // namespace palp::view
