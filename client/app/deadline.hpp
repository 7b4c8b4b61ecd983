// Screenshot mode ends within --timeout whatever the frame loop is doing. The loop checks the
// timeout after each frame and says why it ends; this is for a frame that never returns (a scene
// the checks let through that the renderer cannot draw, a driver): kDeadlineGraceS after the
// timeout it says what the link was doing and ends the process, exit code 1.
#pragma once

#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace palp::view {

inline constexpr double kDeadlineGraceS = 3.0;

class Deadline {
 public:
  // After `seconds`, unless destroyed first: prints "palpview: " + describe() and _Exit(1).
  Deadline(double seconds, std::function<std::string()> describe);
  ~Deadline();
  Deadline(const Deadline&) = delete;
  Deadline& operator=(const Deadline&) = delete;

 private:
  std::mutex mutex_;
  std::condition_variable done_cv_;
  bool done_ = false;
  std::thread thread_;
};

}  // namespace palp::view
