// The screenshot deadline (see the header).
#include "app/deadline.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>

namespace palp::view {

Deadline::Deadline(double seconds, std::function<std::string()> describe) {
  thread_ = std::thread([this, seconds, describe = std::move(describe)] {
    std::unique_lock<std::mutex> lock(mutex_);
    if (done_cv_.wait_for(lock, std::chrono::duration<double>(seconds), [this] { return done_; }))
      return;
    std::fprintf(stderr, "palpview: %s\n", describe().c_str());
    std::fflush(stderr);
    std::fflush(stdout);
    std::_Exit(1);
  });
}

Deadline::~Deadline() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    done_ = true;
  }
  done_cv_.notify_all();
  thread_.join();
}

}  // namespace palp::view
