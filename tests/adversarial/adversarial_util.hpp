// Helpers of the adversarial suite: run a built binary as a child with its output in files, a
// wall-clock limit and its peak memory (ru_maxrss from wait4: the child's own peak, or that of
// a child it waited for, whichever is larger), and read a running process's VmHWM.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include "support/io_test_util.hpp"

namespace palp::adversarial {

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A child process whose stdout and stderr go to files.
class Child {
 public:
  Child(const std::vector<std::string>& argv, const std::filesystem::path& out,
        const std::filesystem::path& err, const std::vector<std::string>& env = {}) {
    pid_ = ::fork();
    if (pid_ != 0) return;
    const int o = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int e = err == out ? o : ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int in = ::open("/dev/null", O_RDONLY);
    ::dup2(o, 1);
    ::dup2(e, 2);
    ::dup2(in, 0);
    for (const std::string& assignment : env) ::putenv(const_cast<char*>(assignment.c_str()));
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  ~Child() {
    if (pid_ > 0 && !reaped_) {
      ::kill(pid_, SIGKILL);
      wait(60);
    }
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  pid_t pid() const { return pid_; }

  // Waits at most `timeout_s` for the child to end (then kills it); false when it had to be
  // killed.
  bool wait(double timeout_s) {
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    bool in_time = true;
    for (;;) {
      int status = 0;
      rusage usage{};
      const pid_t done = ::wait4(pid_, &status, WNOHANG, &usage);
      if (done == pid_) {
        reaped_ = true;
        exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        signal_ = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
        peak_bytes_ = static_cast<std::size_t>(usage.ru_maxrss) * 1024;
        seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
        return in_time;
      }
      if (done < 0) return false;
      if (in_time && std::chrono::steady_clock::now() > deadline) {
        in_time = false;
        ::kill(pid_, SIGKILL);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }

  void signal(int sig) const { ::kill(pid_, sig); }

  // While it runs: the peak resident memory the kernel has seen (VmHWM), 0 when unknown.
  std::size_t vm_hwm_bytes() const {
    std::ifstream status("/proc/" + std::to_string(pid_) + "/status");
    std::string key;
    while (status >> key) {
      if (key == "VmHWM:") {
        std::size_t kib = 0;
        status >> kib;
        return kib * 1024;
      }
    }
    return 0;
  }

  int exit_code() const { return exit_code_; }
  int signal_number() const { return signal_; }
  std::size_t peak_bytes() const { return peak_bytes_; }
  double seconds() const { return seconds_; }

 private:
  pid_t pid_ = -1;
  bool reaped_ = false;
  int exit_code_ = -1;
  int signal_ = 0;
  std::size_t peak_bytes_ = 0;
  double seconds_ = 0.0;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

inline int count_lines(const std::string& text) {
  int lines = 0;
  for (char c : text) lines += c == '\n';
  return lines;
}

// Writes all of `bytes` to the socket `fd` (no SIGPIPE); false when the peer is gone.
inline bool send_all(int fd, const std::string& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL);
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

// A fresh directory for one test binary, removed at exit.
class ScratchDir : public testing::TempDir {
 public:
  explicit ScratchDir(const std::string& name) : TempDir("adversarial-" + name) {}
};

}  // namespace palp::adversarial
