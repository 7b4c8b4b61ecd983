// Clock sync: see clock_sync.hpp.
#include "stream/clock_sync.hpp"

#include <algorithm>
#include <chrono>
#include <cstddef>

namespace palp::view::net {

namespace {

constexpr std::size_t kClockSamples = 32;  // min-RTT filter window (Pings)
constexpr int kFastPings = 5;              // first Pings 100 ms apart, then 1 s

}  // namespace

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

std::int64_t ping_gap_ns(int pings_sent) {
  return pings_sent < kFastPings ? kSecond / 10 : kSecond;
}

void ClockSync::add_pong(std::int64_t sent, std::int64_t server_time, std::int64_t now,
                         std::int64_t started) {
  if (sent < started || sent > now) return;  // not one of this connection's Pings
  const std::int64_t rtt = now - sent;
  const std::int64_t offset = server_time - (sent + rtt / 2);
  samples_.emplace_back(rtt, offset);
  if (samples_.size() > kClockSamples) samples_.pop_front();
  const auto best = std::min_element(samples_.begin(), samples_.end());
  have_offset_ = true;
  rtt_ns_ = best->first;
  offset_ns_ = best->second;
}

double median_latency_ms(const Arrivals& arrivals, const ClockSync& clock,
                         std::vector<double>& scratch) {
  scratch.clear();
  if (clock.have_offset())
    for (const auto& [arrival, stamp] : arrivals)
      scratch.push_back(static_cast<double>(arrival + clock.offset_ns() - stamp) * 1e-6);
  double median = -1;
  if (!scratch.empty()) {
    const auto mid = scratch.begin() + static_cast<std::ptrdiff_t>(scratch.size() / 2);
    std::nth_element(scratch.begin(), mid, scratch.end());
    median = *mid;
  }
  return median;
}

}  // namespace palp::view::net
