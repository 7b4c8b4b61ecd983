// A minimal fork-join helper for preprocessing (not for the haptic tick): splits [0, n) into
// contiguous chunks and runs them on up to `threads` std::threads it owns for the call.
#pragma once

#include <sched.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <exception>
#include <thread>
#include <vector>

namespace palp {

// Number of worker threads preprocessing uses by default: the CPUs this thread may run on (its
// affinity mask: `taskset`, a container's cpuset), else the hardware concurrency; at least 1.
// More workers than those CPUs only take turns on them (measured: a 512x512x400 prep under
// `taskset -c 0-1` on a 16-CPU machine took 10.3-11.4 s with 16 workers).
inline unsigned default_thread_count() {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (sched_getaffinity(0, sizeof allowed, &allowed) == 0) {
    const int n = CPU_COUNT(&allowed);
    if (n > 0) return static_cast<unsigned>(n);
  }
  const unsigned n = std::thread::hardware_concurrency();
  return n == 0 ? 1 : n;
}

// What a `threads` option of 0 means everywhere in palp: default_thread_count().
inline unsigned thread_count_or_default(unsigned threads) {
  return threads != 0 ? threads : default_thread_count();
}

// Calls body(begin, end) on disjoint chunks covering [0, n). Chunks are claimed dynamically in
// pieces of `grain` items so uneven work balances. The first exception thrown is rethrown.
// threads == 0 means default_thread_count() (thread_count_or_default).
template <class Body>
void parallel_for_chunks(std::int64_t n, std::int64_t grain, Body&& body,
                         unsigned threads = default_thread_count()) {
  if (n <= 0) return;
  grain = std::max<std::int64_t>(grain, 1);
  threads = thread_count_or_default(threads);
  const std::int64_t chunks = (n + grain - 1) / grain;
  const unsigned workers = static_cast<unsigned>(std::min<std::int64_t>(threads, chunks));
  if (workers <= 1) {
    body(std::int64_t{0}, n);
    return;
  }
  std::atomic<std::int64_t> next{0};
  std::vector<std::exception_ptr> errors(workers);
  auto work = [&](unsigned w) {
    try {
      for (std::int64_t c = next.fetch_add(1); c < chunks; c = next.fetch_add(1)) {
        body(c * grain, std::min(n, (c + 1) * grain));
      }
    } catch (...) {
      errors[w] = std::current_exception();
      next.store(chunks);
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(workers - 1);
  for (unsigned w = 1; w < workers; ++w) pool.emplace_back(work, w);
  work(0);
  for (auto& t : pool) t.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace palp
