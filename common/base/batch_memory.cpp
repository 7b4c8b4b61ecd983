#include "base/batch_memory.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace palp {

void keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  // Blocks below this come from the heap and are reused once freed; glibc's own limit for it
  // (4 * sizeof(long) MiB). Larger ones (a 512x512x400 mask) stay separate mappings.
  constexpr int kLargestReusedBlock = 32 << 20;
  mallopt(M_MMAP_THRESHOLD, kLargestReusedBlock);
  // Never hand the heap's free top back to the kernel during the command (it ends soon).
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}

}  // namespace palp
