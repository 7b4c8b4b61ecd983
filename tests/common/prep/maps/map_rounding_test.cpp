// The maps' rounding (common/prep/maps/map_rounding.hpp): nearest_integer must be std::nearbyint
// bit for bit (sign of zero, ties to even, infinities, NaN), since the maps' bytes depend on it.
#include <gtest/gtest.h>

#include <cfenv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include "prep/maps/map_rounding.hpp"

namespace palp {
namespace {

std::uint32_t bits(float v) {
  std::uint32_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

TEST(MapRounding, NearestIntegerIsNearbyintBitForBit) {
  ASSERT_EQ(std::fegetround(), FE_TONEAREST);
  std::vector<float> values = {0.0f,
                               -0.0f,
                               0.3f,
                               -0.3f,
                               0.5f,
                               -0.5f,
                               1.5f,
                               -1.5f,
                               2.5f,
                               -2.5f,
                               61439.5f,
                               -61440.49f,
                               4194303.5f,
                               4194304.5f,
                               8388607.5f,
                               -8388607.5f,
                               8388608.0f,
                               8388609.0f,
                               16777216.0f,
                               3.0e30f,
                               std::numeric_limits<float>::infinity(),
                               -std::numeric_limits<float>::infinity(),
                               std::numeric_limits<float>::denorm_min(),
                               -std::numeric_limits<float>::min()};
  // Every float between -2^24 and 2^24 on a stride that visits all exponents and many fractions.
  for (std::uint32_t b = 0; b < 0x4b800000u; b += 9973u) {
    float v;
    std::memcpy(&v, &b, sizeof v);
    values.push_back(v);
    values.push_back(-v);
  }
  for (const float v : values)
    EXPECT_EQ(bits(nearest_integer(v)), bits(std::nearbyint(v))) << "value " << v;
  EXPECT_TRUE(std::isnan(nearest_integer(std::numeric_limits<float>::quiet_NaN())));
}

TEST(MapRounding, MapStepIsOne1024thOfAMillimetre) {
  EXPECT_EQ(round_to_map_step(1.0f / 2048.0f), 0.0f);            // a tie: to even, 0
  EXPECT_EQ(round_to_map_step(3.0f / 2048.0f), 2.0f / 1024.0f);  // a tie: to even, 2/1024
  EXPECT_EQ(round_to_map_step(-12.3456f), std::nearbyint(-12.3456f * 1024.0f) / 1024.0f);
  EXPECT_EQ(round_to_map_step(60.0f), 60.0f);
}

}  // namespace
}  // namespace palp
