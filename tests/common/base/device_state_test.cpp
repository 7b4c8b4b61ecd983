// The device states' names, the one table palpd, palp probe and palpview print
// (common/base/device_state.cpp).
#include "base/device_state.hpp"

#include <gtest/gtest.h>

#include <string>

namespace palp {
namespace {

TEST(DeviceState, NamesAsPrintedEverywhere) {
  EXPECT_EQ(std::string(to_string(DeviceState::Present)), "present");
  EXPECT_EQ(std::string(to_string(DeviceState::Absent)), "absent");
  EXPECT_EQ(std::string(to_string(DeviceState::Fault)), "fault");
  EXPECT_EQ(std::string(to_string(DeviceState::Unknown)), "unknown");
  EXPECT_EQ(std::string(to_string(static_cast<DeviceState>(200))), "unknown");
}

TEST(DeviceState, NumbersArePalpV1s) {
  // palp.v1's DeviceState: UNSPECIFIED 0, PRESENT 1, ABSENT 2, FAULT 3 (proto/palp.proto).
  EXPECT_EQ(static_cast<int>(DeviceState::Unknown), 0);
  EXPECT_EQ(static_cast<int>(DeviceState::Present), 1);
  EXPECT_EQ(static_cast<int>(DeviceState::Absent), 2);
  EXPECT_EQ(static_cast<int>(DeviceState::Fault), 3);
}

}  // namespace
}  // namespace palp
