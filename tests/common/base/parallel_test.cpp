// The preprocessing's fork-join helper: how many workers it takes by default, and that its chunks
// cover the range once.
#include "base/parallel.hpp"

#include <gtest/gtest.h>
#include <sched.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>
#include <vector>

namespace palp {
namespace {

// The affinity mask decides (taskset, a container's cpuset): with one CPU allowed there is one
// worker, with the whole mask as many as it holds.
TEST(DefaultThreadCount, FollowsTheCpusThisThreadMayRunOn) {
  cpu_set_t all;
  CPU_ZERO(&all);
  ASSERT_EQ(sched_getaffinity(0, sizeof all, &all), 0);
  EXPECT_EQ(default_thread_count(), static_cast<unsigned>(CPU_COUNT(&all)));
  int first = 0;
  while (!CPU_ISSET(first, &all)) ++first;
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(first, &one);
  ASSERT_EQ(sched_setaffinity(0, sizeof one, &one), 0);
  const unsigned pinned = default_thread_count();
  ASSERT_EQ(sched_setaffinity(0, sizeof all, &all), 0);  // restored before asserting
  EXPECT_EQ(pinned, 1u);
  EXPECT_EQ(default_thread_count(), static_cast<unsigned>(CPU_COUNT(&all)));
}

TEST(ParallelForChunks, CoversTheRangeOnceForAnyThreadCount) {
  for (const unsigned threads : {1u, 2u, 7u}) {
    std::vector<int> hits(1000, 0);
    parallel_for_chunks(
        static_cast<std::int64_t>(hits.size()), 13,
        [&](std::int64_t begin, std::int64_t end) {
          for (std::int64_t i = begin; i < end; ++i) ++hits[static_cast<std::size_t>(i)];
        },
        threads);
    for (const int h : hits) ASSERT_EQ(h, 1) << threads;
  }
}

// threads == 0 is the default count, not one worker: map_refine's upsample_aligned passed its
// default 0 straight through and ran on one thread. Each chunk waits (at most 10 s) until as many
// workers as the default count have arrived, so a serial run cannot reach that number.
TEST(ParallelForChunks, ZeroThreadsMeansTheDefaultCount) {
  cpu_set_t all;
  CPU_ZERO(&all);
  ASSERT_EQ(sched_getaffinity(0, sizeof all, &all), 0);
  int first = 0, second = 0;
  while (!CPU_ISSET(first, &all)) ++first;
  for (second = first + 1; second < CPU_SETSIZE && !CPU_ISSET(second, &all); ++second) {
  }
  cpu_set_t two;  // two CPUs allowed, wherever the test runs (one when it may use only one)
  CPU_ZERO(&two);
  CPU_SET(first, &two);
  if (second < CPU_SETSIZE) CPU_SET(second, &two);
  ASSERT_EQ(sched_setaffinity(0, sizeof two, &two), 0);
  const unsigned expected = default_thread_count();
  // The fewest workers any chunk saw arrived when its wait ended: 1 for a serial run.
  std::atomic<unsigned> arrived{0}, fewest_seen{~0u};
  parallel_for_chunks(
      static_cast<std::int64_t>(expected), 1,
      [&](std::int64_t, std::int64_t) {
        ++arrived;
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
        while (arrived.load() < expected && std::chrono::steady_clock::now() < deadline)
          std::this_thread::yield();
        const unsigned now = arrived.load();
        unsigned seen = fewest_seen.load();
        while (now < seen && !fewest_seen.compare_exchange_weak(seen, now)) {
        }
      },
      0);
  ASSERT_EQ(sched_setaffinity(0, sizeof all, &all), 0);
  EXPECT_EQ(expected, second < CPU_SETSIZE ? 2u : 1u);
  EXPECT_EQ(fewest_seen.load(), expected);
}

}  // namespace
}  // namespace palp
