#include "loop/wake.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/prctl.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

#include "base/errors.hpp"
#include "loop/atomic_max.hpp"

namespace palp::rt {
namespace {

void cpu_relax() noexcept {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield" ::: "memory");
#endif
}

class SystemClock final : public WakeClock {
 public:
  std::int64_t now() noexcept override { return monotonic_ns(); }
  void sleep_until(std::int64_t t_ns) noexcept override {
    timespec ts{};
    ts.tv_sec = static_cast<time_t>(t_ns / 1'000'000'000);
    ts.tv_nsec = static_cast<long>(t_ns % 1'000'000'000);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
  }
};

std::int64_t us_to_ns(double us) {
  return static_cast<std::int64_t>(std::llround(us * 1e3));
}

}  // namespace

std::int64_t monotonic_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::size_t jitter_bucket(std::int64_t late_ns) noexcept {
  const double us = late_ns > 0 ? static_cast<double>(late_ns) * 1e-3 : 0.0;
  for (std::size_t b = 0; b < kJitterBucketUpperUs.size(); ++b)
    if (us < kJitterBucketUpperUs[b]) return b;
  return kJitterBucketUpperUs.size();
}

const char* to_string(WakeMode mode) noexcept {
  return mode == WakeMode::Sleep ? "sleep" : "hybrid";
}

WakeMode parse_wake_mode(const std::string& text) {
  if (text == "sleep") return WakeMode::Sleep;
  if (text == "hybrid") return WakeMode::Hybrid;
  throw UsageError("--wake must be sleep or hybrid, not '" + text + "'");
}

WakeClock& system_clock() noexcept {
  static SystemClock clock;
  return clock;
}

Waker::Waker(WakeConfig config, std::int64_t period_ns, WakeClock& clock)
    : config_(config), period_ns_(period_ns), clock_(clock) {
  if (period_ns <= 0) throw UsageError("wake-up: the period must be positive");
  if (!(config.spin_us >= 0.0)) throw UsageError("--spin-us must not be negative");
  if (!(config.quantile > 0.0 && config.quantile <= 1.0))
    throw UsageError("wake-up: the quantile must be in (0, 1]");
  max_window_ns_ =
      static_cast<std::int64_t>(config.spin_max_fraction * static_cast<double>(period_ns));
  max_window_ns_ = std::clamp<std::int64_t>(max_window_ns_, 0, period_ns);
  max_window_ns_ = std::min(max_window_ns_, us_to_ns(config.spin_max_us));
  if (config.mode == WakeMode::Hybrid) {
    adaptive_ = config.spin_us == 0.0;
    const std::int64_t start =
        adaptive_ ? window_for(0) : std::min(us_to_ns(config.spin_us), period_ns);
    window_ns_.store(start, std::memory_order_relaxed);
  }
}

std::int64_t Waker::window_for(std::int64_t quantile_ns) const noexcept {
  const std::int64_t wanted = quantile_ns + us_to_ns(config_.margin_us);
  const std::int64_t lo = std::min(us_to_ns(config_.spin_min_us), max_window_ns_);
  return std::clamp(wanted, lo, max_window_ns_);
}

std::int64_t Waker::wait_until(std::int64_t deadline_ns) noexcept {
  std::int64_t now = clock_.now();
  if (config_.mode == WakeMode::Sleep) {
    if (now < deadline_ns) {
      clock_.sleep_until(deadline_ns);
      now = clock_.now();
      record(now - deadline_ns);
    }
    return now;
  }
  const std::int64_t target = deadline_ns - window_ns_.load(std::memory_order_relaxed);
  if (now < target) {
    clock_.sleep_until(target);
    now = clock_.now();
    record(now - target);
  }
  if (now < deadline_ns) {
    // The spin: bounded by the deadline, which is at most one window away.
    const std::int64_t began = now;
    while (now < deadline_ns) {
      cpu_relax();
      now = clock_.now();
    }
    spins_.fetch_add(1, std::memory_order_relaxed);
    spin_ns_.fetch_add(static_cast<std::uint64_t>(now - began), std::memory_order_relaxed);
  }
  return now;
}

void Waker::record(std::int64_t latency_ns) noexcept {
  latency_ns = std::max<std::int64_t>(latency_ns, 0);
  latency_[jitter_bucket(latency_ns)].fetch_add(1, std::memory_order_relaxed);
  store_max(latency_max_ns_, latency_ns);
  sleeps_.fetch_add(1, std::memory_order_relaxed);
  if (!adaptive_) return;
  const auto bin = static_cast<std::size_t>(
      std::min<std::int64_t>(latency_ns / kFineBinNs, static_cast<std::int64_t>(kFineBins) - 1));
  ++fine_[bin];
  if (++fine_count_ >= config_.adapt_every) adapt();
}

std::int64_t Waker::fine_quantile() const noexcept {
  if (fine_count_ == 0) return 0;
  const double wanted = config_.quantile * static_cast<double>(fine_count_);
  std::uint64_t seen = 0;
  for (std::size_t b = 0; b < kFineBins; ++b) {
    seen += fine_[b];
    if (static_cast<double>(seen) >= wanted) return static_cast<std::int64_t>(b + 1) * kFineBinNs;
  }
  return static_cast<std::int64_t>(kFineBins) * kFineBinNs;
}

void Waker::adapt() noexcept {
  const std::int64_t target = window_for(fine_quantile());
  const std::int64_t now = window_ns_.load(std::memory_order_relaxed);
  // Grow at once (late wake-ups cost deadlines); shrink by a quarter of the gap per window (one
  // quiet window should not undo what a busy one taught).
  const std::int64_t next = target >= now ? target : now - (now - target) / 4;
  if (next != now) {
    window_ns_.store(next, std::memory_order_relaxed);
    adaptations_.fetch_add(1, std::memory_order_relaxed);
  }
  fine_.fill(0);
  fine_count_ = 0;
}

std::int64_t Waker::calibrate() noexcept {
  if (config_.mode != WakeMode::Hybrid || !adaptive_) return spin_window_ns();
  fine_.fill(0);
  fine_count_ = 0;
  const std::int64_t budget_ns = 100'000'000;
  const std::int64_t sleep_ns = std::min<std::int64_t>(period_ns_, 1'000'000);
  std::int64_t spent = 0;
  for (std::uint32_t i = 0; i < config_.calibrate_sleeps && spent < budget_ns; ++i) {
    const std::int64_t asked = clock_.now() + sleep_ns;
    clock_.sleep_until(asked);
    const std::int64_t latency = std::max<std::int64_t>(clock_.now() - asked, 0);
    ++fine_[static_cast<std::size_t>(
        std::min<std::int64_t>(latency / kFineBinNs, static_cast<std::int64_t>(kFineBins) - 1))];
    ++fine_count_;
    spent += sleep_ns + latency;
  }
  const std::int64_t q = fine_quantile();
  const std::int64_t window = window_for(q);
  window_ns_.store(window, std::memory_order_relaxed);
  calibrated_quantile_ns_.store(q, std::memory_order_relaxed);
  calibrated_window_ns_.store(window, std::memory_order_relaxed);
  fine_.fill(0);
  fine_count_ = 0;
  return window;
}

WakeStats Waker::stats() const {
  WakeStats s;
  s.mode = config_.mode;
  for (std::size_t b = 0; b < kJitterBuckets; ++b)
    s.latency[b] = latency_[b].load(std::memory_order_relaxed);
  s.latency_max_ns = latency_max_ns_.load(std::memory_order_relaxed);
  s.sleeps = sleeps_.load(std::memory_order_relaxed);
  s.spins = spins_.load(std::memory_order_relaxed);
  s.spin_ns = spin_ns_.load(std::memory_order_relaxed);
  s.spin_window_ns = spin_window_ns();
  s.calibrated_window_ns = calibrated_window_ns_.load(std::memory_order_relaxed);
  s.calibrated_quantile_ns = calibrated_quantile_ns_.load(std::memory_order_relaxed);
  s.adaptations = adaptations_.load(std::memory_order_relaxed);
  return s;
}

// ------------------------------------------------------------------ thread helpers

std::string minimise_timer_slack() noexcept {
  if (prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL) != 0)
    return std::string("PR_SET_TIMERSLACK refused: ") + std::strerror(errno);
  return {};
}

std::string pin_this_thread(int cpu) {
  if (cpu < 0 || cpu >= CPU_SETSIZE) return "no CPU " + std::to_string(cpu);
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  const int rc = pthread_setaffinity_np(pthread_self(), sizeof set, &set);
  if (rc != 0) return "cannot pin to CPU " + std::to_string(cpu) + ": " + std::strerror(rc);
  return {};
}

std::string keep_this_thread_off(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (pthread_getaffinity_np(pthread_self(), sizeof set, &set) != 0) return "cannot read affinity";
  if (cpu < 0 || cpu >= CPU_SETSIZE) return "no CPU " + std::to_string(cpu);
  CPU_CLR(cpu, &set);
  if (CPU_COUNT(&set) == 0)
    return "CPU " + std::to_string(cpu) + " is the only one allowed: the other threads share it";
  const int rc = pthread_setaffinity_np(pthread_self(), sizeof set, &set);
  if (rc != 0)
    return "cannot keep threads off CPU " + std::to_string(cpu) + ": " + std::strerror(rc);
  return {};
}

std::string allowed_cpus_text() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return "?";
  std::string out;
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (!CPU_ISSET(c, &set)) continue;
    int last = c;
    while (last + 1 < CPU_SETSIZE && CPU_ISSET(last + 1, &set)) ++last;
    if (!out.empty()) out.push_back(',');
    out.append(std::to_string(c));
    if (last > c) out.append(1, '-').append(std::to_string(last));
    c = last;
  }
  return out;
}

bool cpu_allowed(int cpu) {
  if (cpu < 0 || cpu >= CPU_SETSIZE) return false;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return false;
  return CPU_ISSET(cpu, &set);
}

std::int64_t thread_cpu_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace palp::rt
