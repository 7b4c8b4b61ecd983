// The controller's pulse keys (client/app/pulse_keys.cpp) without a window: , and . step the rate
// by 6 bpm within [0, 240], B turns the pulse off and back on at the rate it had (72 when it was
// never on), and nothing is sent when nothing changes.
#include "app/pulse_keys.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace palp::view {
namespace {

TEST(PulseKeys, StepsWithinTheRange) {
  double last_on = 0;
  EXPECT_EQ(pulse_request(72, {1, false}, last_on), 78.0);
  EXPECT_EQ(pulse_request(72, {-2, false}, last_on), 60.0);
  EXPECT_EQ(pulse_request(238, {1, false}, last_on), 240.0);
  EXPECT_EQ(pulse_request(240, {1, false}, last_on), std::nullopt);  // at the top already
  EXPECT_EQ(pulse_request(4, {-1, false}, last_on), 0.0);
  EXPECT_EQ(pulse_request(0, {-1, false}, last_on), std::nullopt);
  EXPECT_EQ(pulse_request(72, {0, false}, last_on), std::nullopt);  // no key
}

TEST(PulseKeys, BTurnsThePulseOffAndBackOn) {
  double last_on = 0;
  EXPECT_EQ(pulse_request(0, {0, true}, last_on), 72.0);  // never on: a resting rate
  EXPECT_EQ(pulse_request(90, {0, true}, last_on), 0.0);
  EXPECT_EQ(last_on, 90.0);
  EXPECT_EQ(pulse_request(0, {0, true}, last_on), 90.0);  // back at the rate it had
  EXPECT_EQ(pulse_request(0, {1, true}, last_on), 96.0);  // and a step with it
  EXPECT_EQ(pulse_request(std::nan(""), {1, false}, last_on), 6.0);  // no rate known: from 0
}

}  // namespace
}  // namespace palp::view
