#include "cli_common/palpd_stats.hpp"

#include <sys/resource.h>

#include <cmath>
#include <fstream>

#include "base/errors.hpp"
#include "scene/trajectory.hpp"

namespace palp::cli {

namespace {
std::string json_number(double v) {
  return std::isfinite(v) ? number_text(v) : "null";
}
}  // namespace

double histogram_bound_us(const std::array<std::uint64_t, rt::kJitterBuckets>& counts, double q) {
  std::uint64_t total = 0;
  for (const std::uint64_t n : counts) total += n;
  if (total == 0) return NAN;
  const double wanted = q * static_cast<double>(total);
  std::uint64_t seen = 0;
  for (std::size_t b = 0; b < rt::kJitterBucketUpperUs.size(); ++b) {
    seen += counts[b];
    if (static_cast<double>(seen) >= wanted) return rt::kJitterBucketUpperUs[b];
  }
  return NAN;
}

// --stats-json: one object with the loop's and the server's final counters.
void write_stats_json(const std::string& path, const rt::LoopStats& s, const net::ServerCounters& c,
                      double rate_hz, double elapsed_s) {
  const auto u = [](std::uint64_t v) { return std::to_string(v); };
  const std::uint64_t deadlines = s.ticks + s.overruns;
  // Appended piece by piece: one long operator+ chain trips GCC 12's -Wrestrict false positive.
  std::string out;
  const auto field = [&out](const char* key, const std::string& value, const char* sep = ",") {
    out.append(sep).append("\"").append(key).append("\":").append(value);
  };
  field("rate_hz", json_number(rate_hz), "{");
  field("elapsed_s", json_number(elapsed_s));
  field("ticks", u(s.ticks));
  field("overruns", u(s.overruns));
  field("deadline_miss_fraction",
        json_number(deadlines ? static_cast<double>(s.overruns) / static_cast<double>(deadlines)
                              : 0.0));
  field("faults", u(s.faults));
  field("device_absent_events", u(s.absent_events));
  field("realtime", s.realtime ? "true" : "false");
  field("lateness_us", "");
  field("p50_at_most", json_number(histogram_bound_us(s.jitter, 0.5)), "{");
  field("p99_at_most", json_number(histogram_bound_us(s.jitter, 0.99)));
  field("p999_at_most", json_number(histogram_bound_us(s.jitter, 0.999)));
  field("max", json_number(static_cast<double>(s.max_late_ns) * 1e-3));
  field("bucket_upper_us", "[");
  for (std::size_t b = 0; b < rt::kJitterBucketUpperUs.size(); ++b)
    out.append(b ? "," : "").append(json_number(rt::kJitterBucketUpperUs[b]));
  out.append("]");
  field("counts", "[");
  for (std::size_t b = 0; b < s.jitter.size(); ++b) out.append(b ? "," : "").append(u(s.jitter[b]));
  out.append("]}");
  field("tick_us", "");
  field(
      "mean",
      json_number(s.ticks ? static_cast<double>(s.tick_ns_sum) * 1e-3 / static_cast<double>(s.ticks)
                          : 0.0),
      "{");
  field("max", json_number(static_cast<double>(s.tick_ns_max) * 1e-3));
  out.append("}");
  // how the loop waited (--wake) and what it cost: the kernel's wake-up latency, the spin
  const double running = static_cast<double>(s.running_ns);
  const auto of_running = [running](double ns) { return running > 0 ? ns / running : 0.0; };
  field("wake", "");
  field("mode", std::string("\"") + rt::to_string(s.wake.mode) + "\"", "{");
  field("spin_window_us", json_number(static_cast<double>(s.wake.spin_window_ns) * 1e-3));
  field("calibrated_window_us",
        json_number(static_cast<double>(s.wake.calibrated_window_ns) * 1e-3));
  field("adaptations", u(s.wake.adaptations));
  field("spin_cpu_fraction", json_number(of_running(static_cast<double>(s.wake.spin_ns))));
  field("loop_cpu_fraction",
        json_number(s.loop_cpu_wall_ns > 0 ? static_cast<double>(s.loop_cpu_ns) /
                                                 static_cast<double>(s.loop_cpu_wall_ns)
                                           : 0.0));
  field("latency_p50_us_at_most", json_number(histogram_bound_us(s.wake.latency, 0.5)));
  field("latency_p99_us_at_most", json_number(histogram_bound_us(s.wake.latency, 0.99)));
  field("latency_p999_us_at_most", json_number(histogram_bound_us(s.wake.latency, 0.999)));
  field("latency_max_us", json_number(static_cast<double>(s.wake.latency_max_ns) * 1e-3));
  field("latency_counts", "[");
  for (std::size_t b = 0; b < s.wake.latency.size(); ++b)
    out.append(b ? "," : "").append(u(s.wake.latency[b]));
  out.append("]}");
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
  };
  field("process_cpu_s", json_number(seconds(usage.ru_utime) + seconds(usage.ru_stime)));
  field("net_signals", u(s.net_signals));
  field("net_wakeups", u(c.net_wakeups));
  field("net_published", u(s.net_published));
  field("net_dropped", u(s.net_dropped));
  field("clients_accepted", u(c.accepted));
  field("clients_rejected", u(c.rejected));
  field("protocol_errors", u(c.protocol_errors));
  field("timeouts", u(c.timeouts));
  field("frames_sent", u(c.frames_sent));
  field("frames_dropped", u(c.frames_dropped));
  out.append("}\n");
  std::ofstream file(path);
  file << out;
  if (!file) throw Error("cannot write " + path);
}

}  // namespace palp::cli
