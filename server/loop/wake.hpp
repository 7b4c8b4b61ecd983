// How the haptic loop waits for each tick's deadline, and the deadline accounting around it.
//
//   Waker           waits until an absolute CLOCK_MONOTONIC deadline, in one of two modes:
//                   sleep   clock_nanosleep(TIMER_ABSTIME) to the deadline (every wake-up pays
//                           the kernel's timer slack and scheduling latency);
//                   hybrid  sleep until `spin window` before the deadline, then spin on the
//                           clock up to it (bounded by the deadline itself). The window follows
//                           the measured wake-up latency: calibrated at start, then every
//                           `adapt_every` wake-ups set to its `quantile` plus a margin, between
//                           `spin_min_us` and the smaller of `spin_max_us` and
//                           `spin_max_fraction` of the period (a loop that spins too much of
//                           the period would meet the kernel's real-time throttling, and
//                           leaves no CPU to the rest of the machine).
//                   Every wake-up's latency (woke - asked) goes into a histogram; the time spent
//                   spinning is summed (the CPU cost of the precision).
//   DeadlineTicker  tick n is due at first + n * period; when a tick ends past the next deadline
//                   the deadlines already passed are skipped (phase kept) and counted as
//                   overruns.
// The Waker takes a WakeClock, so tests drive them with an injected clock. Neither allocates,
// locks, logs or throws once constructed.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <string>

namespace palp::rt {

// CLOCK_MONOTONIC in nanoseconds (the time base of every snapshot and message).
std::int64_t monotonic_ns() noexcept;

// Upper bounds (µs) of the lateness and wake-up latency histograms; one more bucket counts
// everything beyond.
inline constexpr std::array<double, 12> kJitterBucketUpperUs = {1,   2,   5,   10,   20,   50,
                                                                100, 200, 500, 1000, 2000, 5000};
inline constexpr std::size_t kJitterBuckets = kJitterBucketUpperUs.size() + 1;
// The bucket of a lateness (ns; negative counts as 0).
std::size_t jitter_bucket(std::int64_t late_ns) noexcept;

enum class WakeMode : std::uint8_t { Sleep = 0, Hybrid = 1 };
const char* to_string(WakeMode mode) noexcept;
// "sleep" or "hybrid"; UsageError otherwise.
WakeMode parse_wake_mode(const std::string& text);

struct WakeConfig {
  WakeMode mode = WakeMode::Hybrid;
  double spin_us = 0.0;                  // hybrid: a fixed window (at most the period); 0: adaptive
  double spin_min_us = 10.0;             // adaptive window bounds
  double spin_max_fraction = 0.5;        // of the period,
  double spin_max_us = 200.0;            // and at most this: later wake-ups are stalls a spin
                                         // cannot hide, only pay for
  double margin_us = 20.0;               // added to the latency quantile
  double quantile = 0.99;                // of the wake-up latency the window covers
  std::uint32_t adapt_every = 1024;      // wake-ups per adaptation
  std::uint32_t calibrate_sleeps = 100;  // sleeps of calibrate() (at most 0.1 s of them)
};

// The time source of the wake-up logic: the real one, or one injected by tests.
class WakeClock {
 public:
  virtual ~WakeClock() = default;
  virtual std::int64_t now() noexcept = 0;
  virtual void sleep_until(std::int64_t t_ns) noexcept = 0;  // absolute
};
// CLOCK_MONOTONIC; sleep_until is clock_nanosleep(TIMER_ABSTIME), EINTR retried.
WakeClock& system_clock() noexcept;

struct WakeStats {
  WakeMode mode = WakeMode::Hybrid;
  std::array<std::uint64_t, kJitterBuckets> latency{};  // wake-up latency histogram
  std::int64_t latency_max_ns = 0;
  std::uint64_t sleeps = 0;                 // wake-ups measured (hybrid: sleeps before a spin)
  std::uint64_t spins = 0;                  // waits that ended in a spin
  std::uint64_t spin_ns = 0;                // time spent spinning, in all
  std::int64_t spin_window_ns = 0;          // the window now (0 in sleep mode)
  std::int64_t calibrated_window_ns = 0;    // as calibrate() chose it
  std::int64_t calibrated_quantile_ns = 0;  // the latency quantile calibrate() measured
  std::uint64_t adaptations = 0;            // window changes after calibration
};

class Waker {
 public:
  // Fine histogram the window is chosen from: 4 µs bins up to 2 ms (beyond: the last bin).
  static constexpr std::int64_t kFineBinNs = 4'000;
  static constexpr std::size_t kFineBins = 512;

  // UsageError for a period <= 0 or a fixed window below zero.
  Waker(WakeConfig config, std::int64_t period_ns, WakeClock& clock);

  // Returns once `deadline_ns` has come (or at once when it has passed), with the time then.
  std::int64_t wait_until(std::int64_t deadline_ns) noexcept;
  // Hybrid and adaptive: measures calibrate_sleeps sleeps (a period each, at most 1 ms; 0.1 s
  // in all at most) and sets the first window from them. Returns the window.
  std::int64_t calibrate() noexcept;

  std::int64_t spin_window_ns() const noexcept {
    return window_ns_.load(std::memory_order_relaxed);
  }
  // The window a latency quantile asks for, within the bounds (pure; tests).
  std::int64_t window_for(std::int64_t quantile_ns) const noexcept;
  WakeStats stats() const;
  const WakeConfig& config() const { return config_; }
  std::int64_t period_ns() const { return period_ns_; }

 private:
  void record(std::int64_t latency_ns) noexcept;
  // The configured quantile of the fine histogram (upper edge of its bin), 0 when empty.
  std::int64_t fine_quantile() const noexcept;
  void adapt() noexcept;

  WakeConfig config_;
  std::int64_t period_ns_;
  WakeClock& clock_;
  std::int64_t max_window_ns_ = 0;
  bool adaptive_ = false;
  std::array<std::uint32_t, kFineBins> fine_{};
  std::uint32_t fine_count_ = 0;

  std::atomic<std::int64_t> window_ns_{0};
  std::array<std::atomic<std::uint64_t>, kJitterBuckets> latency_{};
  std::atomic<std::int64_t> latency_max_ns_{0};
  std::atomic<std::uint64_t> sleeps_{0}, spins_{0}, spin_ns_{0}, adaptations_{0};
  std::atomic<std::int64_t> calibrated_window_ns_{0}, calibrated_quantile_ns_{0};
};

class DeadlineTicker {
 public:
  DeadlineTicker(std::int64_t period_ns, Waker& waker) : period_ns_(period_ns), waker_(waker) {}

  struct Due {
    std::int64_t deadline_ns;  // first + n * period
    std::int64_t now_ns;       // when the wait returned
  };
  // The first deadline; the next wait() waits for it.
  void start(std::int64_t first_deadline_ns) noexcept {
    first_ns_ = first_deadline_ns;
    n_ = 0;
  }
  // Waits for the current deadline.
  Due wait() noexcept {
    const std::int64_t deadline = first_ns_ + n_ * period_ns_;
    return {deadline, waker_.wait_until(deadline)};
  }
  // The tick ended at `end_ns`: moves to the next deadline, skipping (and returning the count
  // of) those already passed.
  std::uint64_t finish(std::int64_t end_ns) noexcept {
    ++n_;
    const std::int64_t next = first_ns_ + n_ * period_ns_;
    if (end_ns <= next) return 0;
    const std::int64_t missed = (end_ns - next) / period_ns_ + 1;
    n_ += missed;
    return static_cast<std::uint64_t>(missed);
  }
  std::int64_t next_deadline_ns() const noexcept { return first_ns_ + n_ * period_ns_; }

 private:
  std::int64_t period_ns_;
  Waker& waker_;
  std::int64_t first_ns_ = 0;
  std::int64_t n_ = 0;
};

// Real-time thread helpers (not for the tick itself). Each returns an empty string or what went
// wrong, for a report.
// The calling thread's timer slack to 1 ns (PR_SET_TIMERSLACK).
std::string minimise_timer_slack() noexcept;
// Pins the calling thread to `cpu`.
std::string pin_this_thread(int cpu);
// Takes `cpu` out of the calling thread's allowed CPUs (threads it starts later inherit this).
std::string keep_this_thread_off(int cpu);
// The CPUs this process may run on, as "0-3" / "0,2"; and whether `cpu` is one of them.
std::string allowed_cpus_text();
bool cpu_allowed(int cpu);
// CPU time of the calling thread (CLOCK_THREAD_CPUTIME_ID), ns.
std::int64_t thread_cpu_ns() noexcept;

}  // namespace palp::rt
