// palpd's force history for late joiners (server/net/force_history.cpp): decimated to the
// interval, bounded to the window, oldest first, the forces as given.
#include "net/force_history.hpp"

#include <gtest/gtest.h>

#include "base/errors.hpp"

namespace palp::net {
namespace {

TEST(ForceHistory, DecimatesToTheIntervalAndKeepsTheWindow) {
  ForceHistory history(1.0, 0.1);  // 1 s at 10 Hz
  // 3 s of 1 kHz ticks, force x = the tick number.
  for (std::int64_t tick = 0; tick < 3000; ++tick)
    history.add(tick * 1'000'000, {static_cast<double>(tick), -1.0, 2.0});
  v1::ForceHistory out;
  history.fill(&out);
  EXPECT_DOUBLE_EQ(out.interval_s(), 0.1);
  // Kept: ticks 0, 100, ..., 2900; within 1 s of the newest (2900): 1900 ... 2900.
  ASSERT_EQ(out.server_time_ns_size(), 11);
  ASSERT_EQ(out.fx_size(), 11);
  for (int i = 0; i < 11; ++i) {
    EXPECT_EQ(out.server_time_ns(i), (1900 + 100 * i) * 1'000'000LL);
    EXPECT_EQ(out.fx(i), 1900.0 + 100 * i);
    EXPECT_EQ(out.fy(i), -1.0);
    EXPECT_EQ(out.fz(i), 2.0);
  }
}

TEST(ForceHistory, EmptyAtStartAndBadSizesRefused) {
  ForceHistory history;
  v1::ForceHistory out;
  history.fill(&out);
  EXPECT_EQ(out.server_time_ns_size(), 0);
  EXPECT_THROW(ForceHistory(1.0, 0.0), UsageError);
  EXPECT_THROW(ForceHistory(0.1, 1.0), UsageError);
  EXPECT_THROW(ForceHistory(1e6, 1e-3), UsageError);
}

}  // namespace
}  // namespace palp::net
