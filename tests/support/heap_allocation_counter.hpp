// Counts heap allocations for "no allocation per tick" tests: replaces the global allocation
// functions and counts every operator new while g_count_allocations is set. Include it in exactly
// one source file of a test executable (each x_test.cpp under tests/ is its own executable).
#pragma once

#include <atomic>
#include <cstdlib>
#include <new>

inline std::atomic<bool> g_count_allocations{false};
inline std::atomic<long> g_allocations{0};

// GCC 12 cannot see that these replacements pair up (it warns -Wmismatched-new-delete on the free
// in operator delete), so that warning is off in files that include this.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
[[gnu::noinline]] void* operator new(std::size_t n) {
  if (g_count_allocations.load(std::memory_order_relaxed))
    g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void* operator new[](std::size_t n) {
  return ::operator new(n);
}
[[gnu::noinline]] void operator delete(void* p) noexcept {
  std::free(p);
}
[[gnu::noinline]] void operator delete[](void* p) noexcept {
  std::free(p);
}
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
[[gnu::noinline]] void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}
