#include "rt/wake_signal.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include "base/errors.hpp"

namespace palp::rt {

WakeSignal::WakeSignal() : fd_(eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {
  if (fd_ < 0) throw ResourceError(std::string("cannot make an eventfd: ") + std::strerror(errno));
}

WakeSignal::~WakeSignal() {
  if (fd_ >= 0) ::close(fd_);
}

void WakeSignal::attach(bool coalesce) noexcept {
  mode_.store(coalesce ? kCoalesce : kEvery, std::memory_order_release);
}

void WakeSignal::detach() noexcept {
  mode_.store(kDetached, std::memory_order_release);
}

void WakeSignal::arm() noexcept {
  armed_.store(true, std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_seq_cst);
}

std::uint64_t WakeSignal::consume() noexcept {
  std::uint64_t value = 0;
  if (::read(fd_, &value, sizeof value) != static_cast<ssize_t>(sizeof value)) return 0;
  return value;
}

void WakeSignal::notify(std::int64_t t_ns, bool urgent) noexcept {
  const int mode = mode_.load(std::memory_order_relaxed);
  if (mode == kDetached) return;
  if (mode == kCoalesce) {
    std::atomic_thread_fence(std::memory_order_seq_cst);
    if (!armed_.load(std::memory_order_relaxed)) return;  // the reader is busy: it looks again
    if (!urgent && t_ns < due_ns_.load(std::memory_order_relaxed)) return;  // nobody due yet
    if (!armed_.exchange(false, std::memory_order_relaxed)) return;
  }
  const std::uint64_t one = 1;
  // EFD_NONBLOCK: EAGAIN only when the counter would overflow, and then the reader is woken
  // anyway; nothing else to do about a failure here.
  if (::write(fd_, &one, sizeof one) == static_cast<ssize_t>(sizeof one))
    writes_.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace palp::rt
