// How the network thread learns that the loop published frames, on its Asio io_context:
//   event        (default) the loop signals an eventfd (rt/wake_signal.hpp) when the network
//                thread is waiting and a snapshot is due for a client (the callback says when, with
//                WakeSignal::want_from, before the pump arms), and the io thread waits on it
//                (asio::posix::stream_descriptor): frames go out as soon as they are due, and an
//                idle network thread sleeps
//   event-every  the same, the loop writing the eventfd after every snapshot (one syscall a tick)
//   poll         a timer every poll interval (the frames wait up to that interval)
// Each wake-up runs the server's callback once (it drains the ring). A backstop timer runs it
// too, every 20 ms in the event modes, so housekeeping tied to it goes on, and the ring is drained,
// when the loop wakes nobody.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>

#include "asio.hpp"
#include "rt/snapshot.hpp"
#include "rt/wake_signal.hpp"

namespace palp::net {

enum class NetWake : std::uint8_t { Event = 0, EventEvery = 1, Poll = 2 };
const char* to_string(NetWake mode) noexcept;
// "event", "event-every" or "poll"; UsageError otherwise.
NetWake parse_net_wake(const std::string& text);

class FramePump {
 public:
  // `ring` and `signal` are the loop's (they outlive the pump); `on_frames` runs on the io thread.
  FramePump(asio::io_context& io, const rt::SnapshotRing& ring, rt::WakeSignal& signal,
            NetWake mode, double poll_interval_s, std::function<void()> on_frames);
  ~FramePump();
  FramePump(const FramePump&) = delete;
  FramePump& operator=(const FramePump&) = delete;

  void start();  // call on the io thread or before it runs
  void stop();   // on the io thread: cancels the waits and detaches from the signal

  std::uint64_t wakeups() const { return wakeups_.load(std::memory_order_relaxed); }

 private:
  void wait_event();
  void schedule_timer();
  void fire();

  const rt::SnapshotRing& ring_;
  rt::WakeSignal& signal_;
  NetWake mode_;
  std::int64_t interval_ns_;
  std::function<void()> on_frames_;
  asio::posix::stream_descriptor descriptor_;
  asio::steady_timer timer_;
  bool stopped_ = false;
  std::atomic<std::uint64_t> wakeups_{0};
};

}  // namespace palp::net
