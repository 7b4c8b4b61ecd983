#include "cli/check_rate.hpp"

#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <thread>

#include "base/errors.hpp"
#include "cli/palpd_stats.hpp"
#include "loop/wake.hpp"

namespace palp::cli {
namespace {

struct Outcome {
  std::array<std::uint64_t, rt::kJitterBuckets> late{};
  std::int64_t late_max_ns = 0;
  std::uint64_t ticks = 0, overruns = 0, past_watchdog = 0;
  std::int64_t cpu_ns = 0, wall_ns = 0;
  std::string setup;
};

constexpr std::int64_t kWatchdogNs = 5'000'000;  // palpd's default --watchdog-ms

std::string bound_text(const std::array<std::uint64_t, rt::kJitterBuckets>& h, double q) {
  const double b = histogram_bound_us(h, q);
  char text[48];
  if (std::isfinite(b))
    std::snprintf(text, sizeof text, "<= %g us", b);
  else
    std::snprintf(text, sizeof text, "> %g us", rt::kJitterBucketUpperUs.back());
  return text;
}

std::string histogram_text(const std::array<std::uint64_t, rt::kJitterBuckets>& h) {
  std::string out;
  for (std::size_t b = 0; b < h.size(); ++b) {
    char text[48];
    if (b < rt::kJitterBucketUpperUs.size())
      std::snprintf(text, sizeof text, " <%gus:%llu", rt::kJitterBucketUpperUs[b],
                    static_cast<unsigned long long>(h[b]));
    else
      std::snprintf(text, sizeof text, " more:%llu", static_cast<unsigned long long>(h[b]));
    out += text;
  }
  return out;
}

std::string json_array(const std::array<std::uint64_t, rt::kJitterBuckets>& h) {
  std::string out = "[";
  for (std::size_t b = 0; b < h.size(); ++b) out.append(b ? "," : "").append(std::to_string(h[b]));
  return out + "]";
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  char text[48];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

}  // namespace

bool wants_check_rate(const Arguments& argv) {
  for (const std::string& a : argv)
    if (a == "--check-rate" || a.rfind("--check-rate=", 0) == 0) return true;
  return false;
}

int cmd_check_rate(const Arguments& argv) {
  const Args args(argv, {"help", "quiet", "no-realtime"},
                  {"check-rate", "duration", "wake", "spin-us", "rt-cpu", "work-us", "max-miss"});
  if (args.has("help")) {
    std::cout << "usage: palp probe --check-rate HZ [--duration S] [options]\n\n"
              << "A timing test of this machine, no server needed (--duration: default 5 s).\n"
              << kCheckRateHelp;
    return 0;
  }
  if (!args.positional().empty())
    throw UsageError("probe --check-rate takes no HOST:PORT (it times this machine)");
  const double rate = args.number("check-rate", 0);
  if (!(rate >= 1 && rate <= 100000)) throw UsageError("--check-rate must be in [1, 100000] Hz");
  const double duration = args.number("duration", 5.0);
  if (!(duration >= 0.1 && duration <= 3600)) throw UsageError("--duration must be in [0.1, 3600]");
  const double work_us = args.number("work-us", 5.0);
  if (!(work_us >= 0 && work_us <= 1e6)) throw UsageError("--work-us must be in [0, 1000000]");
  const double max_miss = args.number("max-miss", 0.1);
  if (!(max_miss >= 0 && max_miss <= 100)) throw UsageError("--max-miss must be in [0, 100] %");
  rt::WakeConfig wake;
  wake.mode = rt::parse_wake_mode(args.get("wake").value_or("hybrid"));
  wake.spin_us = args.number("spin-us", 0.0);
  if (!(wake.spin_us >= 0 && wake.spin_us <= 1e6))
    throw UsageError("--spin-us must be in [0, 1000000]");
  const double cpu_arg = args.number("rt-cpu", -1);
  int cpu = -1;
  if (args.get("rt-cpu")) {
    if (!(cpu_arg >= 0 && cpu_arg < 1024) || cpu_arg != std::floor(cpu_arg) ||
        !rt::cpu_allowed(static_cast<int>(cpu_arg)))
      throw UsageError("--rt-cpu must be a CPU this process may use (" + rt::allowed_cpus_text() +
                       ")");
    cpu = static_cast<int>(cpu_arg);
  }
  const bool quiet = args.has("quiet");
  const auto period = static_cast<std::int64_t>(1e9 / rate + 0.5);
  const auto work_ns = static_cast<std::int64_t>(work_us * 1e3);
  rt::Waker waker(wake, period, rt::system_clock());

  Outcome r;
  std::atomic<int> setup{0};
  std::thread thread([&] {
    while (setup.load(std::memory_order_acquire) == 0) std::this_thread::yield();
    if (wake.mode == rt::WakeMode::Hybrid) {
      const std::string slack = rt::minimise_timer_slack();
      if (!slack.empty()) r.setup += "; " + slack;
    }
    waker.calibrate();
    rt::DeadlineTicker ticker(period, waker);
    const std::int64_t cpu0 = rt::thread_cpu_ns();
    const std::int64_t start = rt::monotonic_ns();
    const std::int64_t end = start + static_cast<std::int64_t>(duration * 1e9);
    ticker.start(start + period);
    for (;;) {
      const rt::DeadlineTicker::Due due = ticker.wait();
      if (due.deadline_ns >= end) break;
      const std::int64_t late = due.now_ns - due.deadline_ns;
      ++r.late[rt::jitter_bucket(late)];
      r.late_max_ns = std::max(r.late_max_ns, late);
      if (late > kWatchdogNs) ++r.past_watchdog;
      ++r.ticks;
      while (rt::monotonic_ns() - due.now_ns < work_ns) {
      }
      r.overruns += ticker.finish(rt::monotonic_ns());
    }
    r.cpu_ns = rt::thread_cpu_ns() - cpu0;
    r.wall_ns = rt::monotonic_ns() - start;
  });
  std::string setup_text;
  if (cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    setup_text += pthread_setaffinity_np(thread.native_handle(), sizeof set, &set) == 0
                      ? "pinned to CPU " + std::to_string(cpu) + ", "
                      : "could not pin to CPU " + std::to_string(cpu) + ", ";
  }
  bool fifo = false;
  if (!args.has("no-realtime")) {
    sched_param param{};
    param.sched_priority = 80;
    fifo = pthread_setschedparam(thread.native_handle(), SCHED_FIFO, &param) == 0;
  }
  setup_text += fifo ? "SCHED_FIFO 80" : "not real time (no SCHED_FIFO)";
  setup.store(1, std::memory_order_release);
  thread.join();
  setup_text += r.setup;

  const rt::WakeStats w = waker.stats();
  const std::uint64_t deadlines = r.ticks + r.overruns;
  const double miss_pct =
      deadlines ? 100.0 * static_cast<double>(r.overruns) / static_cast<double>(deadlines) : 0.0;
  const double wall = static_cast<double>(r.wall_ns);
  const double cpu_frac = wall > 0 ? static_cast<double>(r.cpu_ns) / wall : 0.0;
  const double spin_frac = wall > 0 ? static_cast<double>(w.spin_ns) / wall : 0.0;
  const bool holds = miss_pct <= max_miss && r.past_watchdog == 0 && r.ticks > 0;
  if (!quiet) {
    std::printf("check-rate %g Hz for %g s on this machine (CPUs %s; %s; wake-up %s", rate,
                duration, rt::allowed_cpus_text().c_str(), setup_text.c_str(),
                rt::to_string(w.mode));
    if (w.mode == rt::WakeMode::Hybrid)
      std::printf(
          ", spin window %.0f us at start, %.0f us at the end",
          static_cast<double>(w.calibrated_window_ns ? w.calibrated_window_ns : w.spin_window_ns) *
              1e-3,
          static_cast<double>(w.spin_window_ns) * 1e-3);
    std::printf(")\n");
    std::printf(
        "  deadlines  %llu, missed %llu (%.3f %%), ticks started later than %lld ms: %llu\n",
        static_cast<unsigned long long>(deadlines), static_cast<unsigned long long>(r.overruns),
        miss_pct, static_cast<long long>(kWatchdogNs / 1'000'000),
        static_cast<unsigned long long>(r.past_watchdog));
    std::printf("  lateness   p50 %s, p99 %s, p99.9 %s, max %.1f us (tick start - deadline)\n",
                bound_text(r.late, 0.5).c_str(), bound_text(r.late, 0.99).c_str(),
                bound_text(r.late, 0.999).c_str(), static_cast<double>(r.late_max_ns) * 1e-3);
    std::printf("             %s\n", histogram_text(r.late).c_str());
    std::printf("  wake-up    p50 %s, p99 %s, p99.9 %s, max %.1f us (the kernel's: woke - asked)\n",
                bound_text(w.latency, 0.5).c_str(), bound_text(w.latency, 0.99).c_str(),
                bound_text(w.latency, 0.999).c_str(), static_cast<double>(w.latency_max_ns) * 1e-3);
    std::printf("             %s\n", histogram_text(w.latency).c_str());
    std::printf(
        "  cpu        the timing thread used %.1f %% of a CPU: %.1f %% spinning, %.1f %% "
        "the stand-in tick (%g us)\n",
        100 * cpu_frac, 100 * spin_frac, 100.0 * work_us * 1e-6 * rate, work_us);
    std::printf(
        "verdict: this machine %s %g Hz (%.3f %% of deadlines missed, at most %g %% "
        "allowed; %llu ticks past the watchdog)%s\n",
        holds ? "holds" : "cannot hold", rate, miss_pct, max_miss,
        static_cast<unsigned long long>(r.past_watchdog),
        holds ? ""
              : "; see docs/operations.md (\"A PC for high rates\"): --rt-cpu, isolcpus, "
                "the performance governor, a PREEMPT_RT kernel");
  }
  std::printf(
      "{\"check_rate_hz\":%s,\"holds\":%s,\"wake\":\"%s\",\"deadlines\":%llu,\"missed\":%llu,"
      "\"miss_pct\":%s,\"past_watchdog\":%llu,\"late_max_us\":%s,\"late_counts\":%s,"
      "\"wake_latency_counts\":%s,\"wake_latency_max_us\":%s,\"spin_window_us\":%s,"
      "\"cpu_fraction\":%s,\"spin_fraction\":%s,\"realtime\":%s}\n",
      json_number(rate).c_str(), holds ? "true" : "false", rt::to_string(w.mode),
      static_cast<unsigned long long>(deadlines), static_cast<unsigned long long>(r.overruns),
      json_number(miss_pct).c_str(), static_cast<unsigned long long>(r.past_watchdog),
      json_number(static_cast<double>(r.late_max_ns) * 1e-3).c_str(), json_array(r.late).c_str(),
      json_array(w.latency).c_str(),
      json_number(static_cast<double>(w.latency_max_ns) * 1e-3).c_str(),
      json_number(static_cast<double>(w.spin_window_ns) * 1e-3).c_str(),
      json_number(cpu_frac).c_str(), json_number(spin_frac).c_str(), fifo ? "true" : "false");
  return holds ? 0 : 1;
}

}  // namespace palp::cli
