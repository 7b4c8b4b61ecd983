// Large buffers on transparent huge pages.
//
// palp's volumes are tens to hundreds of MiB each (a 512x512x400 CT: 200 MiB of HU, 400 MiB per
// distance map), and prep makes and frees dozens of them. glibc hands each such block out as
// fresh anonymous memory, and touching it costs one page fault per 4 KiB: on the 2-core VM about
// a third of `palp prep`'s wall time went to faults and their zeroing (docs/benchmarks.md, "Huge
// pages and reused masks"). This replaces the global `operator new(std::size_t)` (the C++
// standard's replaceable allocation function, which std::vector and every container use) with
// one that takes the memory from malloc as before and, for blocks of kHugeMin or more, asks the
// kernel to back it with 2 MiB pages (madvise MADV_HUGEPAGE) before anything touches it. Where
// the kernel's THP setting is "never", or on another system, the hint is ignored; nothing else
// changes, no result depends on it.
//
// Linked into every program through palp::base. It is its own object file (never merged into a
// unity batch: common/base/CMakeLists.txt) and defines nothing else, so a test that replaces
// operator new itself (tests/support/heap_allocation_counter.hpp) keeps its own: the linker never
// pulls this file in for it.
#include <cstdint>
#include <cstdlib>
#include <new>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace {

constexpr std::size_t kHugePage = std::size_t{2} << 20;
// Below this a block spans at most three whole huge pages: not worth a system call.
constexpr std::size_t kHugeMin = 4 * kHugePage;

void advise_huge_pages(void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  const auto begin = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t first = (begin + kHugePage - 1) & ~(std::uintptr_t{kHugePage} - 1);
  const std::uintptr_t last = (begin + bytes) & ~(std::uintptr_t{kHugePage} - 1);
  if (last > first) madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
#else
  (void)data;
  (void)bytes;
#endif
}

}  // namespace

void* operator new(std::size_t size) {
  if (size == 0) size = 1;
  for (;;) {
    if (void* p = std::malloc(size)) {
      if (size >= kHugeMin) advise_huge_pages(p, size);
      return p;
    }
    const std::new_handler handler = std::get_new_handler();
    if (handler == nullptr) throw std::bad_alloc();
    handler();
  }
}
