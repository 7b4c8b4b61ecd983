// Memory policy for a batch command (palp prep and the other `palp` commands): freed blocks of
// up to 32 MiB stay with the process for the next allocation instead of going back to the
// kernel, so a mask freed by one stage is the next stage's mask without fresh page faults and
// the kernel zeroing it again. Long-running programs (palpd, palpview) do not call it: they keep
// the allocator's defaults, which return memory.
#pragma once

namespace palp {

// Call once, at the start of main, before threads start. Glibc only; elsewhere does nothing.
void keep_freed_memory_for_reuse();

}  // namespace palp
