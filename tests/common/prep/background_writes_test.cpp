// BackgroundWrites: jobs run in order on one other thread, a failure skips the rest and is
// rethrown by wait(), and destruction without wait() neither hangs nor throws.
#include "prep/background_writes.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <stdexcept>
#include <thread>

namespace palp {
namespace {

TEST(BackgroundWrites, RunsJobsInOrderOffTheCallingThreadAndFreesWhatTheyOwn) {
  BackgroundWrites writes;
  std::vector<int> order;
  std::thread::id ran_on;
  auto payload = std::make_shared<int>(7);
  std::weak_ptr<int> watch = payload;
  writes.add("a", [&order, &ran_on] {
    ran_on = std::this_thread::get_id();
    order.push_back(1);
  });
  writes.add("b", [&order, owned = std::move(payload)] { order.push_back(*owned); });
  const auto done = writes.wait();
  ASSERT_EQ(done.size(), 2u);
  EXPECT_EQ(done[0].name, "a");
  EXPECT_EQ(done[1].name, "b");
  EXPECT_GE(done[1].seconds, 0.0);
  EXPECT_EQ(order, (std::vector<int>{1, 7}));
  EXPECT_NE(ran_on, std::this_thread::get_id());
  EXPECT_TRUE(watch.expired());        // the job's capture is freed once it has run
  EXPECT_TRUE(writes.wait().empty());  // reported once
}

TEST(BackgroundWrites, AFailureSkipsTheRestAndIsRethrownByWait) {
  BackgroundWrites writes;
  std::atomic<int> ran{0};
  writes.add("ok", [&] { ++ran; });
  writes.add("fails", [] { throw std::runtime_error("disk full"); });
  writes.add("skipped", [&] { ran += 10; });
  EXPECT_THROW(
      {
        try {
          writes.wait();
        } catch (const std::runtime_error& e) {
          EXPECT_STREQ(e.what(), "disk full");
          throw;
        }
      },
      std::runtime_error);
  EXPECT_EQ(ran.load(), 1);
}

TEST(BackgroundWrites, DestructionWithoutWaitFinishesTheRunningJobOnly) {
  std::atomic<int> ran{0};
  std::atomic<bool> started{false};
  {
    BackgroundWrites writes;
    writes.add("slow", [&] {
      started = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      ++ran;
    });
    writes.add("never", [&] { ran += 10; });
    while (!started) std::this_thread::yield();
  }
  EXPECT_EQ(ran.load(), 1);
}

}  // namespace
}  // namespace palp
