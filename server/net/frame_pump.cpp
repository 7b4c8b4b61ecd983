#include "net/frame_pump.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>

#include "base/errors.hpp"

namespace palp::net {

const char* to_string(NetWake mode) noexcept {
  switch (mode) {
    case NetWake::Event:
      return "event";
    case NetWake::EventEvery:
      return "event-every";
    case NetWake::Poll:
      break;
  }
  return "poll";
}

NetWake parse_net_wake(const std::string& text) {
  if (text == "event") return NetWake::Event;
  if (text == "event-every") return NetWake::EventEvery;
  if (text == "poll") return NetWake::Poll;
  throw UsageError("--net-wake must be event, event-every or poll, not '" + text + "'");
}

namespace {
// The stream_descriptor owns what it is given: it gets a duplicate, the signal keeps its own.
int duplicate(int fd) {
  const int copy = ::dup(fd);
  if (copy < 0) throw ResourceError("cannot duplicate the loop's eventfd");
  return copy;
}
}  // namespace

FramePump::FramePump(asio::io_context& io, const rt::SnapshotRing& ring, rt::WakeSignal& signal,
                     NetWake mode, double poll_interval_s, std::function<void()> on_frames)
    : ring_(ring),
      signal_(signal),
      mode_(mode),
      interval_ns_(
          mode == NetWake::Poll
              ? std::max<std::int64_t>(static_cast<std::int64_t>(poll_interval_s * 1e9), 50'000)
              : 20'000'000),
      on_frames_(std::move(on_frames)),
      descriptor_(io, duplicate(signal.fd())),
      timer_(io) {}

FramePump::~FramePump() {
  signal_.detach();
}

void FramePump::start() {
  stopped_ = false;
  if (mode_ != NetWake::Poll) {
    signal_.attach(mode_ == NetWake::Event);
    wait_event();
  }
  schedule_timer();
}

void FramePump::stop() {
  stopped_ = true;
  signal_.detach();
  asio::error_code ec;
  timer_.cancel();
  descriptor_.cancel(ec);
}

void FramePump::fire() {
  wakeups_.fetch_add(1, std::memory_order_relaxed);
  on_frames_();
}

void FramePump::wait_event() {
  if (stopped_) return;
  signal_.arm();
  // A snapshot committed before the arm wrote nothing: take it now rather than a tick later.
  if (ring_.front()) {
    asio::post(descriptor_.get_executor(), [this] {
      if (stopped_) return;
      fire();
      wait_event();
    });
    return;
  }
  descriptor_.async_wait(asio::posix::stream_descriptor::wait_read,
                         [this](const asio::error_code& ec) {
                           if (ec || stopped_) return;
                           signal_.consume();  // reset the counter (never waits)
                           fire();
                           wait_event();
                         });
}

void FramePump::schedule_timer() {
  timer_.expires_after(std::chrono::nanoseconds(interval_ns_));
  timer_.async_wait([this](const asio::error_code& ec) {
    if (ec || stopped_) return;
    fire();
    schedule_timer();
  });
}

}  // namespace palp::net
