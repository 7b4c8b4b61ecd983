// Clock sync (pure, no Asio): local clock, Ping schedule, Ping/Pong offset, latency median.
#pragma once

#include <cstdint>
#include <deque>
#include <utility>
#include <vector>

namespace palp::view::net {

inline constexpr std::int64_t kSecond = 1'000'000'000;

// CLOCK_MONOTONIC on Linux (libstdc++'s steady_clock), the clock palpd stamps frames with: the
// clock offset estimate starts near 0 on the server's own host.
std::int64_t now_ns();

// The gap before the next Ping after `pings_sent` of them: the first few 100 ms apart, then 1 s.
std::int64_t ping_gap_ns(int pings_sent);

// The offset between the server's clock and this one, from Ping/Pong round trips: of the last 32,
// the one with the smallest round-trip time gives offset = server_time - (sent + received) / 2.
class ClockSync {
 public:
  // A Pong to the Ping sent at `sent` (this clock), stamped `server_time` by the server, received
  // at `now`. Ignored when `sent` is not one of this connection's Pings (before `started`, the
  // connection's start, or after `now`).
  void add_pong(std::int64_t sent, std::int64_t server_time, std::int64_t now,
                std::int64_t started);

  bool have_offset() const { return have_offset_; }      // false until the first Pong
  std::int64_t offset_ns() const { return offset_ns_; }  // server clock - this clock
  std::int64_t rtt_ns() const { return rtt_ns_; }        // of the sample the offset comes from

 private:
  std::deque<std::pair<std::int64_t, std::int64_t>> samples_;  // round trip, offset (ns)
  bool have_offset_ = false;
  std::int64_t offset_ns_ = 0, rtt_ns_ = 0;
};

// Frames of the last second: (arrival ns, server_time_ns). Latency is computed from them with the
// current offset, so every sample uses the best estimate.
using Arrivals = std::deque<std::pair<std::int64_t, std::int64_t>>;

// The median frame age on arrival in ms, (arrival + offset) - server_time_ns over `arrivals`; -1
// without an offset or without arrivals. `scratch` is working space kept between calls.
double median_latency_ms(const Arrivals& arrivals, const ClockSync& clock,
                         std::vector<double>& scratch);

}  // namespace palp::view::net
