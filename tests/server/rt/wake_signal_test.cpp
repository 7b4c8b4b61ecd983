// The loop -> network eventfd hand-off: it never blocks the loop, coalesces while the reader is
// not waiting, and loses no wake-up between the reader's last look and its wait.
#include "rt/wake_signal.hpp"

#include <fcntl.h>
#include <poll.h>

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "rt/snapshot.hpp"

namespace palp::rt {
namespace {

bool readable(const WakeSignal& s, int timeout_ms = 0) {
  pollfd p{s.fd(), POLLIN, 0};
  return ::poll(&p, 1, timeout_ms) == 1 && (p.revents & POLLIN);
}

TEST(WakeSignal, IsNonBlockingAndSilentUntilAttached) {
  WakeSignal s;
  EXPECT_NE(fcntl(s.fd(), F_GETFL) & O_NONBLOCK, 0);  // the loop's write can never wait
  s.notify();
  EXPECT_EQ(s.writes(), 0u);
  EXPECT_FALSE(readable(s));
  EXPECT_EQ(s.consume(), 0u);  // and reading an empty one returns at once
}

TEST(WakeSignal, CoalescingWritesOnlyForAWaitingReader) {
  WakeSignal s;
  s.attach(true);
  s.notify();  // not armed: nobody waits, nothing written
  EXPECT_EQ(s.writes(), 0u);
  s.arm();
  s.notify();
  s.notify();  // the reader has not re-armed: coalesced
  EXPECT_EQ(s.writes(), 1u);
  ASSERT_TRUE(readable(s));
  EXPECT_EQ(s.consume(), 1u);
  EXPECT_FALSE(readable(s));
  s.detach();
  s.arm();
  s.notify();
  EXPECT_EQ(s.writes(), 1u);
}

// Issue 41: a waiting reader that nobody's frame is due for is not woken (no system call on
// the loop thread), one whose client is due at t is woken at the first snapshot from t on, and
// an urgent snapshot (the ring filling, the device coming or going) wakes it whatever it wants.
TEST(WakeSignal, AWaitingReaderIsWokenOnlyForDueOrUrgentSnapshots) {
  WakeSignal s;
  s.attach(true);
  EXPECT_EQ(s.wanted_from(), WakeSignal::kEveryTick);  // until told otherwise: every snapshot
  s.want_from(WakeSignal::kNobody);
  s.arm();
  for (std::int64_t t = 0; t < 1000; ++t) s.notify(t);
  EXPECT_EQ(s.writes(), 0u);
  s.want_from(500);
  s.arm();
  for (std::int64_t t = 0; t < 500; ++t) s.notify(t);
  EXPECT_EQ(s.writes(), 0u);
  s.notify(500);
  s.notify(501);  // coalesced: the reader has not re-armed
  EXPECT_EQ(s.writes(), 1u);
  EXPECT_EQ(s.consume(), 1u);
  s.want_from(WakeSignal::kNobody);
  s.arm();
  s.notify(600, true);
  EXPECT_EQ(s.writes(), 2u);
  s.arm();
  s.notify();  // no snapshot time: always due
  EXPECT_EQ(s.writes(), 3u);
}

TEST(WakeSignal, AHalfFullRingWakesAReaderNobodyIsDueFor) {
  SnapshotRing ring(8, 0);
  WakeSignal s;
  s.attach(true);
  s.want_from(WakeSignal::kNobody);
  s.arm();
  for (std::int64_t t = 0; t < 3; ++t) {
    ring.claim();
    commit_and_notify(ring, s, t, false);
  }
  EXPECT_EQ(s.writes(), 0u);
  ring.claim();
  commit_and_notify(ring, s, 3, false);  // 4 of 8: drain it before it drops
  EXPECT_EQ(s.writes(), 1u);
}

TEST(WakeSignal, EveryModeWritesEachPublish) {
  WakeSignal s;
  s.attach(false);
  for (int i = 0; i < 3; ++i) s.notify();
  EXPECT_EQ(s.writes(), 3u);
  EXPECT_EQ(s.consume(), 3u);
}

// The reader's protocol (arm, look once more, then wait) against a producer publishing as fast as
// it can: every snapshot is seen, and no wait outlasts the producer (a lost wake-up would leave
// the reader waiting for the 2 s timeout with snapshots in the ring).
TEST(WakeSignal, NoWakeUpIsLostBetweenTheLastLookAndTheWait) {
  SnapshotRing ring(64, 0);
  WakeSignal s;
  s.attach(true);
  constexpr std::uint64_t kCount = 50'000;
  std::atomic<bool> done{false};
  std::thread producer([&] {
    std::uint64_t sent = 0;
    while (sent < kCount) {
      if (Snapshot* snap = ring.claim()) {
        snap->tick.seq = sent++;
        ring.commit();
        s.notify();
      } else {
        std::this_thread::yield();
      }
    }
    done = true;
  });
  std::uint64_t seen = 0, timeouts = 0;
  while (seen < kCount) {
    while (const Snapshot* snap = ring.front()) {
      EXPECT_EQ(snap->tick.seq, seen);
      ++seen;
      ring.pop();
    }
    if (seen == kCount) break;
    s.arm();
    if (ring.front()) continue;  // committed before the arm: no write was owed
    if (!readable(s, 2000)) {
      ++timeouts;
      if (done) break;
      continue;
    }
    s.consume();
  }
  producer.join();
  EXPECT_EQ(seen, kCount);
  EXPECT_EQ(timeouts, 0u);
  EXPECT_LE(s.writes(), kCount);
}

}  // namespace
}  // namespace palp::rt
