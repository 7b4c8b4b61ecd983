// The loop's "frames published" signal to the network thread: an eventfd the real-time side
// writes without ever blocking (EFD_NONBLOCK; a write is one syscall, EAGAIN - a counter at its
// limit - ignored) and the network thread's event loop waits on.
//
//   consumer (network thread)          producer (the loop, after committing a snapshot)
//     drain; want_from(next due time)    notify(t):
//     arm()                                every:    write on every publish
//     look at the ring once more           coalesce: write only when armed (exchange) and the
//     empty: wait for the fd                         snapshot is due (t >= the wanted time) or
//     readable: consume(), drain                     urgent (the ring filling, a device change)
//
// The write is the loop's only system call besides its sleep, and its price depends on the
// machine (waking a thread on another CPU: ~33 us on a 2-vCPU VM, issue 41), so the loop writes
// only when the reader waits *and* a snapshot is due for someone: the reader says, before it
// arms, the earliest snapshot time (TickRecord::t_ns) a client wants (want_from: the next frame
// of the soonest client at its requested rate; kEveryTick for a client taking every tick;
// kNobody when none is connected, the reader then drains on its own timer). Reading that is one
// relaxed load on the loop's side.
//
// Coalescing writes only when the reader said it is about to wait; the reader looks at the ring
// once more after arming, so a snapshot committed just before the arm is not left waiting for
// the next tick (the two sides' seq_cst fences order "commit, then read the flag and the wanted
// time" against "set the wanted time and the flag, then read the ring"). Until a consumer
// attaches, notify() does nothing.
#pragma once

#include <atomic>
#include <cstdint>
#include <limits>

#include "rt/snapshot.hpp"

namespace palp::rt {

class WakeSignal {
 public:
  WakeSignal();  // ResourceError when no eventfd can be had
  ~WakeSignal();
  WakeSignal(const WakeSignal&) = delete;
  WakeSignal& operator=(const WakeSignal&) = delete;

  int fd() const { return fd_; }

  // Consumer: from now on notify() writes; `coalesce`: only when armed.
  void attach(bool coalesce) noexcept;
  void detach() noexcept;
  // Consumer: the earliest snapshot time it wants to be woken for (kEveryTick: every snapshot,
  // the default; kNobody: none, only urgent ones). Call before arm().
  static constexpr std::int64_t kEveryTick = std::numeric_limits<std::int64_t>::min();
  static constexpr std::int64_t kNobody = std::numeric_limits<std::int64_t>::max();
  void want_from(std::int64_t t_ns) noexcept { due_ns_.store(t_ns, std::memory_order_relaxed); }
  std::int64_t wanted_from() const noexcept { return due_ns_.load(std::memory_order_relaxed); }
  // Consumer: about to wait for fd(); look for data once more after this, before waiting.
  void arm() noexcept;
  // Consumer: after fd() became readable; resets the counter and returns it (0: nothing).
  std::uint64_t consume() noexcept;

  // Producer (real time), after committing the snapshot of time `t_ns`: wakes a waiting reader
  // when it is due (t_ns >= wanted_from()) or `urgent`. Never blocks, allocates or throws; no
  // system call unless it wakes the reader.
  void notify(std::int64_t t_ns, bool urgent = false) noexcept;
  // A wake-up whatever the reader wants (a producer without snapshot times).
  void notify() noexcept { notify(0, true); }

  std::uint64_t writes() const { return writes_.load(std::memory_order_relaxed); }

 private:
  enum : int { kDetached = 0, kCoalesce = 1, kEvery = 2 };
  int fd_ = -1;
  std::atomic<int> mode_{kDetached};
  alignas(64) std::atomic<bool> armed_{false};
  std::atomic<std::int64_t> due_ns_{kEveryTick};
  std::atomic<std::uint64_t> writes_{0};
};

// The producer's side of the hand-off, after filling the slot of ring.claim(): commits it and
// wakes the reader when it waits and the snapshot (time `t_ns`) is due, `urgent`, or the ring is
// half full (the reader drains it before it drops). HapticLoop::publish and the stand-in tick of
// palp probe --check-rate both hand off this way.
inline void commit_and_notify(SnapshotRing& ring, WakeSignal& signal, std::int64_t t_ns,
                              bool urgent) noexcept {
  ring.commit();
  signal.notify(t_ns, urgent || 2 * ring.size() >= ring.capacity());
}

}  // namespace palp::rt
