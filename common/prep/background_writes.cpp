// See background_writes.hpp.
#include "prep/background_writes.hpp"

#include <chrono>
#include <utility>

namespace palp {

BackgroundWrites::~BackgroundWrites() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    queue_.clear();
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void BackgroundWrites::add(std::string name, std::function<void()> job) {
  {
    std::lock_guard lock(mutex_);
    queue_.push_back({std::move(name), std::move(job)});
  }
  if (!thread_.joinable()) thread_ = std::thread([this] { loop(); });
  changed_.notify_all();
}

std::vector<BackgroundWrites::Done> BackgroundWrites::wait() {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [this] { return queue_.empty() && !busy_; });
  if (error_) {
    std::exception_ptr error = std::exchange(error_, nullptr);
    std::rethrow_exception(error);
  }
  return std::exchange(done_, {});
}

void BackgroundWrites::loop() {
  std::unique_lock lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
    if (stopping_) return;
    Job job = std::move(queue_.front());
    queue_.pop_front();
    if (error_) {  // an earlier job failed: the rest are skipped
      changed_.notify_all();
      continue;
    }
    busy_ = true;
    lock.unlock();
    const auto t0 = std::chrono::steady_clock::now();
    std::exception_ptr error;
    try {
      job.run();
    } catch (...) {
      error = std::current_exception();
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    job.run = nullptr;  // frees what the job owned before the pipeline hears it is done
    lock.lock();
    busy_ = false;
    if (error) {
      error_ = error;
    } else {
      done_.push_back({std::move(job.name), seconds});
    }
    changed_.notify_all();
  }
}

}  // namespace palp
