// The loop's "frames published" signal to the network thread: an eventfd the real-time side
// writes without ever blocking (EFD_NONBLOCK; a write is one syscall, EAGAIN - a counter at its
// limit - ignored) and the network thread's event loop waits on.
//
//   consumer (network thread)       producer (the loop, after committing a snapshot)
//     arm()                           notify():
//     look at the ring once more        coalescing: write only when armed (exchange)
//     empty: wait for the fd            every:      write on every publish
//     readable: consume(), drain
//
// Coalescing writes only when the reader said it is about to wait; the reader looks at the ring
// once more after arming, so a snapshot committed just before the arm is not left waiting for
// the next tick (the two sides' seq_cst fences order "commit, then read the flag" against
// "set the flag, then read the ring"). Until a consumer attaches, notify() does nothing.
#pragma once

#include <atomic>
#include <cstdint>

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
  // Consumer: about to wait for fd(); look for data once more after this, before waiting.
  void arm() noexcept;
  // Consumer: after fd() became readable; resets the counter and returns it (0: nothing).
  std::uint64_t consume() noexcept;

  // Producer (real time): never blocks, allocates or throws.
  void notify() noexcept;

  std::uint64_t writes() const { return writes_.load(std::memory_order_relaxed); }

 private:
  enum : int { kDetached = 0, kCoalesce = 1, kEvery = 2 };
  int fd_ = -1;
  std::atomic<int> mode_{kDetached};
  alignas(64) std::atomic<bool> armed_{false};
  std::atomic<std::uint64_t> writes_{0};
};

}  // namespace palp::rt
