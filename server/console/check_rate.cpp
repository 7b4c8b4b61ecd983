#include "console/check_rate.hpp"

#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "base/errors.hpp"
#include "cli_common/palpd_stats.hpp"
#include "console/json_number.hpp"
#include "loop/wake.hpp"
#include "net/frame_pump.hpp"
#include "net/frame_schedule.hpp"
#include "rt/snapshot.hpp"
#include "rt/wake_signal.hpp"

namespace palp::cli {
namespace {

struct Outcome {
  std::array<std::uint64_t, rt::kJitterBuckets> late{};
  std::int64_t late_max_ns = 0;
  std::uint64_t ticks = 0, overruns = 0, past_watchdog = 0;
  std::int64_t cpu_ns = 0, wall_ns = 0;
  std::int64_t step_ns_sum = 0, step_ns_max = 0;  // stand-in tick and hand-off
  bool fifo = false;
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

// The network thread of palpd as far as the loop sees it: the snapshot ring it drains, the
// eventfd (or poll timer) that wakes it, and clients at their frame rates telling the loop when
// the next frame is due (server.cpp's drain and want_frames, without encoding or sockets).
class StandInNetwork {
 public:
  StandInNetwork(net::NetWake mode, std::size_t clients, double client_hz)
      : clients_(clients, net::FrameSchedule{net::frame_interval_ns(client_hz), 0}),
        pump_(io_, ring_, signal_, mode, 0.0005, [this] { drain(); }) {
    signal_.want_from(clients_.empty() ? rt::WakeSignal::kNobody : rt::WakeSignal::kEveryTick);
    pump_.start();
    thread_ = std::thread([this] { io_.run(); });
  }
  ~StandInNetwork() {
    asio::post(io_, [this] {
      pump_.stop();
      io_.stop();
    });
    thread_.join();
  }
  // The loop's side (real time): as HapticLoop::publish.
  void publish(std::int64_t t_ns) noexcept {
    if (rt::Snapshot* s = ring_.claim()) {
      s->tick.t_ns = t_ns;
      rt::commit_and_notify(ring_, signal_, t_ns, false);
    }
  }
  std::uint64_t signals() const { return signal_.writes(); }
  std::uint64_t wakeups() const { return pump_.wakeups(); }
  std::uint64_t dropped() const { return ring_.dropped(); }

 private:
  void drain() {
    std::int64_t due = rt::WakeSignal::kNobody;
    while (const rt::Snapshot* s = ring_.front()) {
      for (net::FrameSchedule& c : clients_) c.take(s->tick.t_ns);
      ring_.pop();
    }
    for (const net::FrameSchedule& c : clients_) due = std::min(due, c.due());
    signal_.want_from(due);
  }

  rt::SnapshotRing ring_{1024, 0};
  rt::WakeSignal signal_;
  std::vector<net::FrameSchedule> clients_;
  asio::io_context io_;
  net::FramePump pump_;
  std::thread thread_;
};

struct CheckRateOptions {
  double rate = 0, duration = 5, work_us = 5, max_miss = 0.1, client_hz = 0;
  std::size_t clients = 0;
  rt::WakeConfig wake;
  net::NetWake net_wake = net::NetWake::Event;
  int cpu = -1;
  bool realtime = true, quiet = false;
};

CheckRateOptions parse_options(const Args& args) {
  if (!args.positional().empty())
    throw UsageError("probe --check-rate takes no HOST:PORT (it times this machine)");
  CheckRateOptions o;
  o.rate = args.number("check-rate", 0);
  if (!(o.rate >= 1 && o.rate <= 100000))
    throw UsageError("--check-rate must be in [1, 100000] Hz");
  o.duration = args.number("duration", 5.0);
  if (!(o.duration >= 0.1 && o.duration <= 3600))
    throw UsageError("--duration must be in [0.1, 3600]");
  o.work_us = args.number("work-us", 5.0);
  if (!(o.work_us >= 0 && o.work_us <= 1e6)) throw UsageError("--work-us must be in [0, 1000000]");
  o.max_miss = args.number("max-miss", 0.1);
  if (!(o.max_miss >= 0 && o.max_miss <= 100)) throw UsageError("--max-miss must be in [0, 100] %");
  o.wake.mode = rt::parse_wake_mode(args.get("wake").value_or("hybrid"));
  o.wake.spin_us = args.number("spin-us", 0.0);
  if (!(o.wake.spin_us >= 0 && o.wake.spin_us <= 1e6))
    throw UsageError("--spin-us must be in [0, 1000000]");
  if (args.get("rt-cpu")) {
    const double cpu = args.number("rt-cpu", -1);
    if (!(cpu >= 0 && cpu < 1024) || cpu != std::floor(cpu) ||
        !rt::cpu_allowed(static_cast<int>(cpu)))
      throw UsageError("--rt-cpu must be a CPU this process may use (" + rt::allowed_cpus_text() +
                       ")");
    o.cpu = static_cast<int>(cpu);
  }
  const double clients = args.number("clients", 0);
  if (!(clients >= 0 && clients <= 1024) || clients != std::floor(clients))
    throw UsageError("--clients must be a whole number in [0, 1024]");
  o.clients = static_cast<std::size_t>(clients);
  o.client_hz = args.number("client-hz", 0);
  if (!(o.client_hz >= 0 && o.client_hz <= o.rate))
    throw UsageError("--client-hz must be in [0, HZ]");
  o.net_wake = net::parse_net_wake(args.get("net-wake").value_or("event"));
  o.realtime = !args.has("no-realtime");
  o.quiet = args.has("quiet");
  return o;
}

// The timing thread, as palpd's loop: wait for the deadline, the stand-in tick, the hand-off.
void time_ticks(const CheckRateOptions& o, std::int64_t period, rt::Waker& waker,
                StandInNetwork& network, const std::atomic<int>& setup, Outcome& r) {
  while (setup.load(std::memory_order_acquire) == 0) std::this_thread::yield();
  if (o.wake.mode == rt::WakeMode::Hybrid) {
    const std::string slack = rt::minimise_timer_slack();
    if (!slack.empty()) r.setup += "; " + slack;
  }
  waker.calibrate();
  rt::DeadlineTicker ticker(period, waker);
  const auto work_ns = static_cast<std::int64_t>(o.work_us * 1e3);
  const std::int64_t cpu0 = rt::thread_cpu_ns();
  const std::int64_t start = rt::monotonic_ns();
  const std::int64_t end = start + static_cast<std::int64_t>(o.duration * 1e9);
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
    network.publish(due.deadline_ns);  // palpd's hand-off, eventfd included
    const std::int64_t step_ns = rt::monotonic_ns() - due.now_ns;
    r.step_ns_sum += step_ns;
    r.step_ns_max = std::max(r.step_ns_max, step_ns);
    r.overruns += ticker.finish(rt::monotonic_ns());
  }
  r.cpu_ns = rt::thread_cpu_ns() - cpu0;
  r.wall_ns = rt::monotonic_ns() - start;
}

// Starts the timing thread pinned and at SCHED_FIFO as asked, and waits for it.
void run_timing_thread(const CheckRateOptions& o, std::int64_t period, rt::Waker& waker,
                       StandInNetwork& network, Outcome& r) {
  std::atomic<int> setup{0};
  std::thread thread([&] { time_ticks(o, period, waker, network, setup, r); });
  std::string setup_text;
  if (o.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(o.cpu, &set);
    setup_text += pthread_setaffinity_np(thread.native_handle(), sizeof set, &set) == 0
                      ? "pinned to CPU " + std::to_string(o.cpu) + ", "
                      : "could not pin to CPU " + std::to_string(o.cpu) + ", ";
  }
  if (o.realtime) {
    sched_param param{};
    param.sched_priority = 80;
    r.fifo = pthread_setschedparam(thread.native_handle(), SCHED_FIFO, &param) == 0;
  }
  setup_text += r.fifo ? "SCHED_FIFO 80" : "not real time (no SCHED_FIFO)";
  setup.store(1, std::memory_order_release);
  thread.join();
  r.setup = setup_text + r.setup;
}

// What the report says, worked out once for the text and the JSON line.
struct Verdict {
  std::uint64_t deadlines = 0;
  double miss_pct = 0, cpu_frac = 0, spin_frac = 0, step_mean_us = 0, step_max_us = 0;
  bool holds = false;
};

Verdict verdict_of(const CheckRateOptions& o, const Outcome& r, const rt::WakeStats& w) {
  Verdict v;
  v.deadlines = r.ticks + r.overruns;
  v.miss_pct = v.deadlines
                   ? 100.0 * static_cast<double>(r.overruns) / static_cast<double>(v.deadlines)
                   : 0.0;
  const double wall = static_cast<double>(r.wall_ns);
  v.cpu_frac = wall > 0 ? static_cast<double>(r.cpu_ns) / wall : 0.0;
  v.spin_frac = wall > 0 ? static_cast<double>(w.spin_ns) / wall : 0.0;
  v.holds = v.miss_pct <= o.max_miss && r.past_watchdog == 0 && r.ticks > 0;
  v.step_mean_us =
      r.ticks ? static_cast<double>(r.step_ns_sum) * 1e-3 / static_cast<double>(r.ticks) : 0.0;
  v.step_max_us = static_cast<double>(r.step_ns_max) * 1e-3;
  return v;
}

void print_text(const CheckRateOptions& o, const Outcome& r, const rt::WakeStats& w,
                const Verdict& v, const StandInNetwork& network) {
  std::printf("check-rate %g Hz for %g s on this machine (CPUs %s; %s; wake-up %s", o.rate,
              o.duration, rt::allowed_cpus_text().c_str(), r.setup.c_str(), rt::to_string(w.mode));
  if (w.mode == rt::WakeMode::Hybrid)
    std::printf(
        ", spin window %.0f us at start, %.0f us at the end",
        static_cast<double>(w.calibrated_window_ns ? w.calibrated_window_ns : w.spin_window_ns) *
            1e-3,
        static_cast<double>(w.spin_window_ns) * 1e-3);
  std::printf(")\n");
  std::printf("  deadlines  %llu, missed %llu (%.3f %%), ticks started later than %lld ms: %llu\n",
              static_cast<unsigned long long>(v.deadlines),
              static_cast<unsigned long long>(r.overruns), v.miss_pct,
              static_cast<long long>(kWatchdogNs / 1'000'000),
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
      100 * v.cpu_frac, 100 * v.spin_frac, 100.0 * o.work_us * 1e-6 * o.rate, o.work_us);
  std::printf(
      "  hand-off   %zu stand-in client(s) at %s (--net-wake %s): %llu eventfd writes "
      "(%.3f a tick), %llu network wake-ups, %llu snapshots dropped; stand-in tick + "
      "hand-off mean %.1f us, max %.1f us\n",
      o.clients, o.client_hz > 0 ? (json_number(o.client_hz) + " Hz").c_str() : "every tick",
      net::to_string(o.net_wake), static_cast<unsigned long long>(network.signals()),
      r.ticks ? static_cast<double>(network.signals()) / static_cast<double>(r.ticks) : 0.0,
      static_cast<unsigned long long>(network.wakeups()),
      static_cast<unsigned long long>(network.dropped()), v.step_mean_us, v.step_max_us);
  std::printf(
      "verdict: this machine %s %g Hz (%.3f %% of deadlines missed, at most %g %% "
      "allowed; %llu ticks past the watchdog)%s\n",
      v.holds ? "holds" : "cannot hold", o.rate, v.miss_pct, o.max_miss,
      static_cast<unsigned long long>(r.past_watchdog),
      v.holds ? ""
              : "; see docs/operations.md (\"A PC for high rates\"): --rt-cpu, isolcpus, "
                "the performance governor, a PREEMPT_RT kernel");
}

void print_json(const CheckRateOptions& o, const Outcome& r, const rt::WakeStats& w,
                const Verdict& v, const StandInNetwork& network) {
  std::printf(
      "{\"check_rate_hz\":%s,\"holds\":%s,\"wake\":\"%s\",\"deadlines\":%llu,\"missed\":%llu,"
      "\"miss_pct\":%s,\"past_watchdog\":%llu,\"late_max_us\":%s,\"late_counts\":%s,"
      "\"wake_latency_counts\":%s,\"wake_latency_max_us\":%s,\"spin_window_us\":%s,"
      "\"cpu_fraction\":%s,\"spin_fraction\":%s,\"realtime\":%s,\"clients\":%zu,"
      "\"client_hz\":%s,\"net_wake\":\"%s\",\"net_signals\":%llu,\"net_wakeups\":%llu,"
      "\"step_mean_us\":%s,\"step_max_us\":%s}\n",
      json_number(o.rate).c_str(), v.holds ? "true" : "false", rt::to_string(w.mode),
      static_cast<unsigned long long>(v.deadlines), static_cast<unsigned long long>(r.overruns),
      json_number(v.miss_pct).c_str(), static_cast<unsigned long long>(r.past_watchdog),
      json_number(static_cast<double>(r.late_max_ns) * 1e-3).c_str(), json_array(r.late).c_str(),
      json_array(w.latency).c_str(),
      json_number(static_cast<double>(w.latency_max_ns) * 1e-3).c_str(),
      json_number(static_cast<double>(w.spin_window_ns) * 1e-3).c_str(),
      json_number(v.cpu_frac).c_str(), json_number(v.spin_frac).c_str(), r.fifo ? "true" : "false",
      o.clients, json_number(o.client_hz).c_str(), net::to_string(o.net_wake),
      static_cast<unsigned long long>(network.signals()),
      static_cast<unsigned long long>(network.wakeups()), json_number(v.step_mean_us).c_str(),
      json_number(v.step_max_us).c_str());
}

}  // namespace

bool wants_check_rate(const Arguments& argv) {
  for (const std::string& a : argv)
    if (a == "--check-rate" || a.rfind("--check-rate=", 0) == 0) return true;
  return false;
}

int cmd_check_rate(const Arguments& argv) {
  const Args args(argv, {"help", "quiet", "no-realtime"},
                  {"check-rate", "duration", "wake", "spin-us", "rt-cpu", "work-us", "max-miss",
                   "clients", "client-hz", "net-wake"});
  if (args.has("help")) {
    std::cout << "usage: palp probe --check-rate HZ [--duration S] [options]\n\n"
              << "A timing test of this machine, no server needed (--duration: default 5 s).\n"
              << kCheckRateHelp;
    return 0;
  }
  const CheckRateOptions o = parse_options(args);
  const auto period = static_cast<std::int64_t>(1e9 / o.rate + 0.5);
  rt::Waker waker(o.wake, period, rt::system_clock());
  StandInNetwork network(o.net_wake, o.clients, o.client_hz);
  Outcome r;
  run_timing_thread(o, period, waker, network, r);
  const rt::WakeStats w = waker.stats();
  const Verdict v = verdict_of(o, r, w);
  if (!o.quiet) print_text(o, r, w, v, network);
  print_json(o, r, w, v, network);
  return v.holds ? 0 : 1;
}

}  // namespace palp::cli
