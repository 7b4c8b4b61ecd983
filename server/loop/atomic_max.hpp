// A running maximum kept in an atomic that one thread writes and others read (the loop's late
// and tick-time maxima, the wake latency): no read-modify-write needed.
#pragma once

#include <atomic>
#include <cstdint>

namespace palp::rt {

// Raises `target` to `value` if larger. Single writer: a plain load-compare-store is enough.
inline void store_max(std::atomic<std::int64_t>& target, std::int64_t value) noexcept {
  if (value > target.load(std::memory_order_relaxed))
    target.store(value, std::memory_order_relaxed);
}

}  // namespace palp::rt
