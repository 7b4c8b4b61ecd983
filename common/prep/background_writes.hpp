// Prep's output files written on one background thread while the pipeline computes the next
// stages (the CT copy and the masks overlap segmentation, which is mostly single-threaded).
// Jobs run in the order queued; each owns what it writes (e.g. a shared_ptr to the volume), so
// the pipeline may drop its own reference at once. A failed job skips the rest and its error
// is rethrown by wait(); destruction without wait() (an exception in the pipeline) lets the
// running job finish, skips the others and swallows their errors.
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace palp {

class BackgroundWrites {
 public:
  struct Done {
    std::string name;
    double seconds = 0.0;  // the job's own wall time on the writer thread
  };

  BackgroundWrites() = default;
  ~BackgroundWrites();
  BackgroundWrites(const BackgroundWrites&) = delete;
  BackgroundWrites& operator=(const BackgroundWrites&) = delete;

  // Queues a job (started on the writer thread, created on the first call).
  void add(std::string name, std::function<void()> job);
  // Blocks until every queued job has run; rethrows the first failure. Returns the jobs finished
  // since the previous wait(), in order.
  std::vector<Done> wait();

 private:
  struct Job {
    std::string name;
    std::function<void()> run;
  };
  void loop();

  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Job> queue_;
  std::vector<Done> done_;
  std::exception_ptr error_;
  bool busy_ = false;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace palp
