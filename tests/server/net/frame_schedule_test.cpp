// Which snapshots a consumer at its own frame rate takes, and the earliest one the network
// thread must be woken for.
#include "net/frame_schedule.hpp"

#include <gtest/gtest.h>

namespace palp::net {
namespace {

TEST(FrameSchedule, EveryTickTakesEverySnapshotAndIsAlwaysDue) {
  FrameSchedule f{frame_interval_ns(0.0), 0};
  EXPECT_EQ(f.interval_ns, 0);
  for (std::int64_t t = 0; t < 5'000'000; t += 1'000'000) EXPECT_TRUE(f.take(t));
  EXPECT_EQ(f.due(), rt::WakeSignal::kEveryTick);
}

TEST(FrameSchedule, ARateTakesOneSnapshotAnIntervalAndSaysWhenTheNextIsDue) {
  FrameSchedule f{frame_interval_ns(250.0), 0};  // 4 ms, ticks 1 ms apart
  EXPECT_EQ(f.interval_ns, 4'000'000);
  EXPECT_TRUE(f.take(10'000'000));  // the first snapshot it sees
  EXPECT_EQ(f.due(), 14'000'000);
  EXPECT_FALSE(f.take(11'000'000));
  EXPECT_FALSE(f.take(13'999'999));
  EXPECT_TRUE(f.take(14'000'000));
  EXPECT_EQ(f.due(), 18'000'000);
  EXPECT_TRUE(f.take(18'500'000));  // a late tick: the next stays on the drift-free schedule
  EXPECT_EQ(f.due(), 22'000'000);
  EXPECT_TRUE(f.take(40'000'000));  // fell far behind: an interval from now
  EXPECT_EQ(f.due(), 44'000'000);
}

}  // namespace
}  // namespace palp::net
