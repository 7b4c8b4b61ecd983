#include "cli_common/palpd_stats.hpp"

#include <sys/resource.h>

#include <cmath>
#include <fstream>

#include "base/errors.hpp"
#include "scene/trajectory.hpp"

namespace palp::cli {

namespace {
// A number as JSON: null when not finite.
std::string json_number(double v) {
  return std::isfinite(v) ? number_text(v) : "null";
}

// A count as JSON.
std::string count_text(std::uint64_t v) {
  return std::to_string(v);
}

// A JSON text written key by key. Appended piece by piece: one long operator+ chain trips GCC
// 12's -Wrestrict false positive.
struct JsonText {
  std::string out;
  // `"key":value`, after `sep` (the comma, or "{" for an object's first key).
  void field(const char* key, const std::string& value, const char* sep = ",") {
    out.append(sep).append("\"").append(key).append("\":").append(value);
  }
  // The array's values, then `close` ("]", or "]}" to end the object too).
  template <typename Values, typename Text>
  void array_values(const Values& values, Text text, const char* close) {
    for (std::size_t b = 0; b < values.size(); ++b)
      out.append(b ? "," : "").append(text(values[b]));
    out.append(close);
  }
};

// "lateness_us": the loop's wake-up lateness, its percentiles' bounds and histogram.
void lateness_fields(JsonText& j, const rt::LoopStats& s) {
  j.field("lateness_us", "");
  j.field("p50_at_most", json_number(histogram_bound_us(s.jitter, 0.5)), "{");
  j.field("p99_at_most", json_number(histogram_bound_us(s.jitter, 0.99)));
  j.field("p999_at_most", json_number(histogram_bound_us(s.jitter, 0.999)));
  j.field("max", json_number(static_cast<double>(s.max_late_ns) * 1e-3));
  j.field("bucket_upper_us", "[");
  j.array_values(rt::kJitterBucketUpperUs, json_number, "]");
  j.field("counts", "[");
  j.array_values(s.jitter, count_text, "]}");
}

// "tick_us": the tick's mean and largest cost.
void tick_fields(JsonText& j, const rt::LoopStats& s) {
  j.field("tick_us", "");
  j.field(
      "mean",
      json_number(s.ticks ? static_cast<double>(s.tick_ns_sum) * 1e-3 / static_cast<double>(s.ticks)
                          : 0.0),
      "{");
  j.field("max", json_number(static_cast<double>(s.tick_ns_max) * 1e-3));
  j.out.append("}");
}

// "wake": how the loop waited (--wake) and what it cost: the kernel's wake-up latency, the spin.
void wake_fields(JsonText& j, const rt::LoopStats& s) {
  const double running = static_cast<double>(s.running_ns);
  const auto of_running = [running](double ns) { return running > 0 ? ns / running : 0.0; };
  j.field("wake", "");
  j.field("mode", std::string("\"") + rt::to_string(s.wake.mode) + "\"", "{");
  j.field("spin_window_us", json_number(static_cast<double>(s.wake.spin_window_ns) * 1e-3));
  j.field("calibrated_window_us",
          json_number(static_cast<double>(s.wake.calibrated_window_ns) * 1e-3));
  j.field("adaptations", count_text(s.wake.adaptations));
  j.field("spin_cpu_fraction", json_number(of_running(static_cast<double>(s.wake.spin_ns))));
  j.field("loop_cpu_fraction",
          json_number(s.loop_cpu_wall_ns > 0 ? static_cast<double>(s.loop_cpu_ns) /
                                                   static_cast<double>(s.loop_cpu_wall_ns)
                                             : 0.0));
  j.field("latency_p50_us_at_most", json_number(histogram_bound_us(s.wake.latency, 0.5)));
  j.field("latency_p99_us_at_most", json_number(histogram_bound_us(s.wake.latency, 0.99)));
  j.field("latency_p999_us_at_most", json_number(histogram_bound_us(s.wake.latency, 0.999)));
  j.field("latency_max_us", json_number(static_cast<double>(s.wake.latency_max_ns) * 1e-3));
  j.field("latency_counts", "[");
  j.array_values(s.wake.latency, count_text, "]}");
}

// The process's CPU time so far (user and system), in seconds.
double process_cpu_s() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
  };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
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
  const std::uint64_t deadlines = s.ticks + s.overruns;
  JsonText j;
  j.field("rate_hz", json_number(rate_hz), "{");
  j.field("elapsed_s", json_number(elapsed_s));
  j.field("ticks", count_text(s.ticks));
  j.field("overruns", count_text(s.overruns));
  j.field("deadline_miss_fraction",
          json_number(deadlines ? static_cast<double>(s.overruns) / static_cast<double>(deadlines)
                                : 0.0));
  j.field("faults", count_text(s.faults));
  j.field("device_absent_events", count_text(s.absent_events));
  j.field("realtime", s.realtime ? "true" : "false");
  lateness_fields(j, s);
  tick_fields(j, s);
  wake_fields(j, s);
  j.field("process_cpu_s", json_number(process_cpu_s()));
  j.field("net_signals", count_text(s.net_signals));
  j.field("net_wakeups", count_text(c.net_wakeups));
  j.field("net_published", count_text(s.net_published));
  j.field("net_dropped", count_text(s.net_dropped));
  j.field("clients_accepted", count_text(c.accepted));
  j.field("clients_rejected", count_text(c.rejected));
  j.field("protocol_errors", count_text(c.protocol_errors));
  j.field("timeouts", count_text(c.timeouts));
  j.field("frames_sent", count_text(c.frames_sent));
  j.field("frames_dropped", count_text(c.frames_dropped));
  j.out.append("}\n");
  std::ofstream file(path);
  file << j.out;
  if (!file) throw Error("cannot write " + path);
}

}  // namespace palp::cli
