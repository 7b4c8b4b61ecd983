// The lock-free hand-offs out of the real-time thread: SnapshotRing and LatestBox.
#include "rt/snapshot.hpp"

#include <gtest/gtest.h>

#include <thread>

namespace palp::rt {
namespace {

TEST(SnapshotRing, RoundsUpAndPreallocatesContacts) {
  SnapshotRing ring(5, 37);
  EXPECT_EQ(ring.capacity(), 8u);
  EXPECT_EQ(ring.contact_capacity(), 37u);
  EXPECT_EQ(ring.front(), nullptr);
}

TEST(SnapshotRing, FifoAndDropsWhenFull) {
  SnapshotRing ring(4, 0);
  for (std::uint64_t i = 0; i < 6; ++i) {
    if (Snapshot* s = ring.claim()) {
      s->tick.seq = i;
      ring.commit();
    }
  }
  EXPECT_EQ(ring.published(), 4u);
  EXPECT_EQ(ring.dropped(), 2u);
  for (std::uint64_t i = 0; i < 4; ++i) {
    const Snapshot* s = ring.front();
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->tick.seq, i);
    ring.pop();
  }
  EXPECT_EQ(ring.front(), nullptr);
  ASSERT_NE(ring.claim(), nullptr);  // room again after the consumer caught up
}

TEST(SnapshotRing, TwoThreadsSeeEveryCommittedSnapshotWhole) {
  SnapshotRing ring(64, 8);
  constexpr std::uint64_t kCount = 200000;
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kCount; ++i) {
      Snapshot* s = ring.claim();
      if (!s) continue;  // dropped, counted
      s->tick.seq = i;
      for (auto& c : s->contacts) c.x = Vec3d{double(i), double(i), double(i)};
      s->contact_count = 8;
      ring.commit();
    }
  });
  std::uint64_t seen = 0, last = 0;
  bool ordered = true, whole = true;
  while (seen + ring.dropped() < kCount || ring.front()) {
    const Snapshot* s = ring.front();
    if (!s) {
      std::this_thread::yield();
      continue;
    }
    if (seen > 0 && s->tick.seq <= last) ordered = false;
    for (const auto& c : s->contacts)
      if (c.x.x != double(s->tick.seq) || c.x.z != double(s->tick.seq)) whole = false;
    last = s->tick.seq;
    ++seen;
    ring.pop();
  }
  producer.join();
  EXPECT_TRUE(ordered);
  EXPECT_TRUE(whole);
  EXPECT_EQ(seen + ring.dropped(), kCount);
  EXPECT_EQ(ring.published(), seen);
}

TEST(LatestBox, ReaderGetsNewestValueOnce) {
  LatestBox<int> box;
  int v = -1;
  EXPECT_FALSE(box.read(v));
  box.write(1);
  box.write(2);
  box.write(3);
  ASSERT_TRUE(box.read(v));
  EXPECT_EQ(v, 3);
  EXPECT_FALSE(box.read(v));
  box.write(4);
  ASSERT_TRUE(box.read(v));
  EXPECT_EQ(v, 4);
}

TEST(LatestBox, ConcurrentValuesAreNeverTorn) {
  struct Pair {
    std::uint64_t a = 0, b = 0;
  };
  LatestBox<Pair> box;
  constexpr std::uint64_t kCount = 200000;
  std::thread writer([&] {
    for (std::uint64_t i = 1; i <= kCount; ++i) box.write(Pair{i, ~i});
  });
  std::uint64_t last = 0;
  bool torn = false, backwards = false;
  while (last < kCount) {
    Pair p;
    if (!box.read(p)) continue;
    if (p.b != ~p.a) torn = true;
    if (p.a <= last) backwards = true;
    last = p.a;
  }
  writer.join();
  EXPECT_FALSE(torn);
  EXPECT_FALSE(backwards);
}

}  // namespace
}  // namespace palp::rt
