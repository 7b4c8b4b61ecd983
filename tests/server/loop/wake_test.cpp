// The loop's wake-up logic and deadline accounting, driven by an injected clock: every figure is
// exact or bounded by the clock's own step. No assertion depends on the machine's timing.
#include "loop/wake.hpp"

#include <gtest/gtest.h>

#include <deque>
#include <vector>

#include "base/errors.hpp"

namespace palp::rt {
namespace {

// A clock that moves only when read (by `step` ns per read: a spin makes progress) or slept on
// (it wakes `latency` after the time asked, or the next of `script` when one is left).
class FakeClock final : public WakeClock {
 public:
  explicit FakeClock(std::int64_t start = 0) : t(start) {}
  std::int64_t now() noexcept override {
    const std::int64_t v = t;
    t += step;
    ++reads;
    return v;
  }
  void sleep_until(std::int64_t asked) noexcept override {
    sleeps.push_back(asked);
    std::int64_t late = latency;
    if (!script.empty()) {
      late = script.front();
      script.pop_front();
    }
    t = std::max(t, asked) + late;
  }
  std::int64_t t;
  std::int64_t step = 1'000;  // 1 us per read
  std::int64_t latency = 0;
  std::deque<std::int64_t> script;
  std::vector<std::int64_t> sleeps;
  std::uint64_t reads = 0;
};

constexpr std::int64_t kMs = 1'000'000, kUs = 1'000;

WakeConfig fixed(double spin_us) {
  WakeConfig c;
  c.mode = WakeMode::Hybrid;
  c.spin_us = spin_us;
  return c;
}

TEST(Wake, ModesParseAndPrint) {
  EXPECT_EQ(parse_wake_mode("sleep"), WakeMode::Sleep);
  EXPECT_EQ(parse_wake_mode("hybrid"), WakeMode::Hybrid);
  EXPECT_STREQ(to_string(WakeMode::Sleep), "sleep");
  EXPECT_THROW(parse_wake_mode("spin"), UsageError);
  FakeClock clock;
  EXPECT_THROW(Waker(fixed(-1), kMs, clock), UsageError);
  EXPECT_THROW(Waker(fixed(0), 0, clock), UsageError);
}

TEST(Wake, SleepModeSleepsToTheDeadlineAndCountsItsLatency) {
  FakeClock clock;
  clock.latency = 30 * kUs;
  WakeConfig c;
  c.mode = WakeMode::Sleep;
  Waker w(c, kMs, clock);
  const std::int64_t woke = w.wait_until(5 * kMs);
  ASSERT_EQ(clock.sleeps.size(), 1u);
  EXPECT_EQ(clock.sleeps[0], 5 * kMs);  // the deadline itself, absolute
  EXPECT_EQ(woke, 5 * kMs + 30 * kUs);
  const WakeStats s = w.stats();
  EXPECT_EQ(s.sleeps, 1u);
  EXPECT_EQ(s.latency[jitter_bucket(30 * kUs)], 1u);  // the 20-50 us bucket
  EXPECT_EQ(s.latency_max_ns, 30 * kUs);
  EXPECT_EQ(s.spins, 0u);
  EXPECT_EQ(s.spin_ns, 0u);
  EXPECT_EQ(s.spin_window_ns, 0);
}

TEST(Wake, HybridSleepsToTheWindowThenSpinsToTheDeadline) {
  FakeClock clock;
  clock.latency = 30 * kUs;
  Waker w(fixed(100), kMs, clock);
  EXPECT_EQ(w.spin_window_ns(), 100 * kUs);
  const std::int64_t woke = w.wait_until(5 * kMs);
  ASSERT_EQ(clock.sleeps.size(), 1u);
  EXPECT_EQ(clock.sleeps[0], 5 * kMs - 100 * kUs);
  // returns on the first read at or after the deadline: within one clock step of it
  EXPECT_GE(woke, 5 * kMs);
  EXPECT_LT(woke, 5 * kMs + clock.step);
  const WakeStats s = w.stats();
  EXPECT_EQ(s.latency[jitter_bucket(30 * kUs)], 1u);  // the kernel's latency, not the lateness
  EXPECT_EQ(s.spins, 1u);
  // woke 70 us before the deadline and spun the rest
  EXPECT_GE(s.spin_ns, static_cast<std::uint64_t>(70 * kUs - clock.step));
  EXPECT_LE(s.spin_ns, static_cast<std::uint64_t>(70 * kUs + clock.step));
}

TEST(Wake, HybridWokenPastTheDeadlineDoesNotSpin) {
  FakeClock clock;
  clock.latency = 150 * kUs;
  Waker w(fixed(100), kMs, clock);
  const std::int64_t woke = w.wait_until(5 * kMs);
  EXPECT_EQ(woke, 5 * kMs + 50 * kUs);
  EXPECT_EQ(w.stats().spins, 0u);
  EXPECT_EQ(w.stats().latency_max_ns, 150 * kUs);
}

TEST(Wake, APassedDeadlineReturnsAtOnceWithoutSleeping) {
  FakeClock clock(7 * kMs);
  Waker w(fixed(100), kMs, clock);
  EXPECT_EQ(w.wait_until(5 * kMs), 7 * kMs);
  EXPECT_TRUE(clock.sleeps.empty());
  EXPECT_EQ(w.stats().sleeps, 0u);
  // inside the window already: no sleep, only the spin
  FakeClock near(5 * kMs - 40 * kUs);
  Waker v(fixed(100), kMs, near);
  EXPECT_GE(v.wait_until(5 * kMs), 5 * kMs);
  EXPECT_TRUE(near.sleeps.empty());
  EXPECT_EQ(v.stats().spins, 1u);
}

TEST(Wake, AFixedWindowIsAtMostThePeriod) {
  FakeClock clock;
  Waker w(fixed(5000), kMs, clock);
  EXPECT_EQ(w.spin_window_ns(), kMs);
}

TEST(Wake, TheAdaptiveWindowIsTheLatencyQuantilePlusAMarginWithinBounds) {
  FakeClock clock;
  // adaptive: quantile 0.99, margin 20 us, at least 10 us, at most half the period and 200 us
  WakeConfig c;
  Waker w(c, kMs, clock);
  EXPECT_EQ(w.window_for(0), 20 * kUs);
  EXPECT_EQ(w.window_for(44 * kUs), 64 * kUs);
  EXPECT_EQ(w.window_for(10 * kMs), 200 * kUs);
  Waker fast(c, 250 * kUs, clock);  // 4 kHz: half the period is the smaller bound
  EXPECT_EQ(fast.window_for(10 * kMs), 125 * kUs);
  c.margin_us = 0;
  Waker v(c, kMs, clock);
  EXPECT_EQ(v.window_for(0), 10 * kUs);  // the minimum
  c.spin_max_fraction = 0.005;           // 5 us: the cap wins over the minimum
  Waker u(c, kMs, clock);
  EXPECT_EQ(u.window_for(0), 5 * kUs);
}

TEST(Wake, TheWindowGrowsAtOnceAndShrinksGently) {
  FakeClock clock;
  WakeConfig c;
  c.adapt_every = 100;
  Waker w(c, kMs, clock);
  std::int64_t deadline = 0;
  const auto run = [&](Waker& waker, std::int64_t latency, int n) {
    clock.latency = latency;
    for (int i = 0; i < n; ++i) {
      deadline = std::max(deadline + kMs, clock.t + 2 * kMs);
      waker.wait_until(deadline);
    }
  };
  run(w, 40 * kUs, 100);  // 40 us is in the 4 us bin [40, 44): the quantile reads 44 us
  EXPECT_EQ(w.spin_window_ns(), 64 * kUs);
  run(w, 4 * kUs, 100);  // quantile 8 us -> 28 us wanted; a quarter of the way there
  EXPECT_EQ(w.spin_window_ns(), 64 * kUs - (64 - 28) * kUs / 4);
  run(w, 700 * kUs, 100);  // at once, up to the cap (200 us)
  EXPECT_EQ(w.spin_window_ns(), 200 * kUs);
  EXPECT_EQ(w.stats().adaptations, 3u);
  // one slow wake-up in a hundred is beyond the 0.99 quantile: the window follows the other 99
  // (8 us: bin [8, 12) -> 12 us + 20 us), not the 900 us one
  Waker v(c, kMs, clock);
  clock.script.assign(99, 8 * kUs);
  clock.script.push_back(900 * kUs);
  run(v, 8 * kUs, 100);
  EXPECT_EQ(v.spin_window_ns(), 32 * kUs);
  EXPECT_EQ(v.stats().latency_max_ns, 900 * kUs);
}

TEST(Wake, CalibrationMeasuresSleepsAndSetsTheFirstWindow) {
  FakeClock clock;
  clock.latency = 40 * kUs;
  WakeConfig c;
  c.calibrate_sleeps = 50;
  Waker w(c, 250 * kUs, clock);
  EXPECT_EQ(w.calibrate(), 64 * kUs);
  EXPECT_EQ(clock.sleeps.size(), 50u);
  const WakeStats s = w.stats();
  EXPECT_EQ(s.calibrated_quantile_ns, 44 * kUs);
  EXPECT_EQ(s.calibrated_window_ns, 64 * kUs);
  EXPECT_EQ(s.sleeps, 0u);  // calibration is not in the loop's histogram
  // bounded in time: at 1 Hz it sleeps 1 ms at a time, 0.1 s in all at most
  FakeClock slow;
  Waker v(c, 1'000 * kMs, slow);
  v.calibrate();
  EXPECT_EQ(slow.sleeps.size(), 50u);
  EXPECT_LE(slow.t, 60 * kMs);
  // a fixed window is not calibrated
  FakeClock fixed_clock;
  Waker u(fixed(100), kMs, fixed_clock);
  EXPECT_EQ(u.calibrate(), 100 * kUs);
  EXPECT_TRUE(fixed_clock.sleeps.empty());
}

TEST(DeadlineTicker, DeadlinesAreAbsoluteAndOverrunsAreCountedAndSkipped) {
  FakeClock clock;
  WakeConfig c;
  c.mode = WakeMode::Sleep;
  clock.latency = 200 * kUs;
  Waker w(c, kMs, clock);
  DeadlineTicker ticker(kMs, w);
  ticker.start(10 * kMs);
  DeadlineTicker::Due due = ticker.wait();
  EXPECT_EQ(due.deadline_ns, 10 * kMs);
  EXPECT_EQ(due.now_ns, 10 * kMs + 200 * kUs);
  // a tick that ends within its period: the next deadline is first + period, not woke + period
  EXPECT_EQ(ticker.finish(10 * kMs + 500 * kUs), 0u);
  EXPECT_EQ(ticker.next_deadline_ns(), 11 * kMs);
  due = ticker.wait();
  EXPECT_EQ(due.deadline_ns, 11 * kMs);
  // ending exactly on the next deadline is not an overrun
  EXPECT_EQ(ticker.finish(12 * kMs), 0u);
  // a tick of this deadline (12 ms) ending at 14.5 ms: 13 and 14 passed, the next is 15 ms
  due = ticker.wait();
  EXPECT_EQ(due.deadline_ns, 12 * kMs);
  EXPECT_EQ(ticker.finish(14 * kMs + 500 * kUs), 2u);
  EXPECT_EQ(ticker.next_deadline_ns(), 15 * kMs);
  ASSERT_FALSE(clock.sleeps.empty());
  EXPECT_EQ(clock.sleeps.back(), 12 * kMs);
  due = ticker.wait();
  EXPECT_EQ(clock.sleeps.back(), 15 * kMs);  // the phase is kept
}

TEST(DeadlineTicker, HybridTicksStartWithinAClockStepOfEveryDeadline) {
  FakeClock clock;
  clock.latency = 30 * kUs;              // less than the window: every tick starts on time
  Waker w(fixed(50), 100 * kUs, clock);  // 10 kHz
  DeadlineTicker ticker(100 * kUs, w);
  ticker.start(100 * kUs);
  std::uint64_t overruns = 0;
  for (int i = 0; i < 1000; ++i) {
    const DeadlineTicker::Due due = ticker.wait();
    EXPECT_EQ(due.deadline_ns, (i + 1) * 100 * kUs);
    EXPECT_LT(due.now_ns - due.deadline_ns, clock.step);
    clock.t += 5 * kUs;  // the tick
    overruns += ticker.finish(clock.now());
  }
  EXPECT_EQ(overruns, 0u);
  const WakeStats s = w.stats();
  EXPECT_EQ(s.spins, 1000u);
  // each wait sleeps to 50 us before its deadline, wakes 30 us later and spins about 20 us
  EXPECT_NEAR(static_cast<double>(s.spin_ns) / 1000.0, 20.0 * kUs, 1.0 * kUs);
}

}  // namespace
}  // namespace palp::rt
