// palpd --stats-json: the loop's and the server's final counters as one JSON object (ticks,
// overruns, the lateness and wake-up latency histograms with percentile bounds, the spin window
// and the CPU the loop used, frames sent).
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "loop/haptic_loop.hpp"
#include "net/server.hpp"

namespace palp::cli {

// The smallest bucket bound (us, kJitterBucketUpperUs) at or below which a fraction q of the
// histogram's counts lie; NaN when it falls in the open last bucket or there are none.
double histogram_bound_us(const std::array<std::uint64_t, rt::kJitterBuckets>& counts, double q);

// Writes the object to `path` (Error when it cannot).
void write_stats_json(const std::string& path, const rt::LoopStats& s, const net::ServerCounters& c,
                      double rate_hz, double elapsed_s);

}  // namespace palp::cli
