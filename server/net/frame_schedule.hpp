// When a consumer taking frames at its own rate (palp.v1's Hello.frame_rate_hz, the bridges'
// --igtl-rate and --dds-rate) takes the next snapshot, and so the earliest snapshot time the
// network thread must be woken for (rt::WakeSignal::want_from): the loop then writes its eventfd
// only for a tick some consumer is due, not for every tick (issue 41).
#pragma once

#include <algorithm>
#include <cstdint>

#include "rt/wake_signal.hpp"

namespace palp::net {

struct FrameSchedule {
  std::int64_t interval_ns = 0;  // 0: every snapshot
  std::int64_t next_ns = 0;      // the next snapshot it takes has t_ns >= this

  // Whether the snapshot of time `t_ns` is one it takes (then the next is an interval on, or an
  // interval after `t_ns` when it fell behind).
  bool take(std::int64_t t_ns) noexcept {
    if (interval_ns <= 0) return true;
    if (t_ns < next_ns) return false;
    next_ns = std::max(next_ns + interval_ns, t_ns);
    if (next_ns <= t_ns) next_ns = t_ns + interval_ns;
    return true;
  }
  // The earliest snapshot time it takes next.
  std::int64_t due() const noexcept {
    return interval_ns > 0 ? next_ns : rt::WakeSignal::kEveryTick;
  }
};

// The interval of a rate in Hz, as palp.v1 and the bridges round it (0 Hz: every snapshot).
inline std::int64_t frame_interval_ns(double rate_hz) noexcept {
  return rate_hz > 0.0 ? static_cast<std::int64_t>(1e9 / rate_hz) : 0;
}

}  // namespace palp::net
