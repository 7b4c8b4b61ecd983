// Running fragile library code in a forked child process that reports back through a pipe.
//
// Debian's GDCM is built with assertions enabled and aborts on malformed DICOM files (a truncated
// slice is enough). To turn such a crash into a clear error, the DICOM reader runs GDCM in a
// child: the child sends typed records (progress, results, errors) and the parent, which never
// calls into GDCM for that work, reports a child that died without finishing.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "base/errors.hpp"

namespace palp {

struct ChildRecord {
  char type = 0;
  std::vector<char> payload;
  std::string text() const { return {payload.begin(), payload.end()}; }
};

// The child's end of the pipe. A failed write means the parent is gone: the child exits.
class ChildWriter {
 public:
  explicit ChildWriter(int fd) : fd_(fd) {}

  void send(char type, const void* data, std::size_t size) {
    const std::uint64_t length = size;
    write_all(&type, 1);
    write_all(&length, sizeof length);
    write_all(data, size);
  }
  void send(char type, const std::string& text) { send(type, text.data(), text.size()); }

 private:
  void write_all(const void* data, std::size_t size) {
    const char* p = static_cast<const char*>(data);
    while (size > 0) {
      const ssize_t n = ::write(fd_, p, size);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) ::_exit(1);
      p += n;
      size -= static_cast<std::size_t>(n);
    }
  }
  int fd_;
};

// Forks a child running body(ChildWriter&) with stdout/stderr on /dev/null and no core dumps;
// the child _exits when body returns (body must not throw). The parent reads its records.
class IsolatedChild {
 public:
  template <class Body>
  explicit IsolatedChild(Body&& body) {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0)
      throw ResourceError(std::string("cannot create a pipe (") + std::strerror(errno) + ")");
    pid_ = ::fork();
    if (pid_ < 0) {
      ::close(fds[0]);
      ::close(fds[1]);
      throw ResourceError(std::string("cannot start a process (") + std::strerror(errno) + ")");
    }
    if (pid_ == 0) {
      ::close(fds[0]);
      silence_child();
      ChildWriter writer(fds[1]);
      body(writer);
      ::_exit(0);
    }
    ::close(fds[1]);
    fd_ = fds[0];
  }

  ~IsolatedChild() {
    if (fd_ >= 0) ::close(fd_);
    if (!reaped_) {
      ::kill(pid_, SIGKILL);
      wait();
    }
  }
  IsolatedChild(const IsolatedChild&) = delete;
  IsolatedChild& operator=(const IsolatedChild&) = delete;

  // The next record; false when the child closed the pipe (finished or died).
  bool next(ChildRecord& record) {
    std::uint64_t length = 0;
    if (!read_all(&record.type, 1)) return false;
    if (!read_all(&length, sizeof length) || length > kMaxPayload) return false;
    record.payload.resize(static_cast<std::size_t>(length));
    return read_all(record.payload.data(), record.payload.size());
  }

  // Reaps the child; true when it exited normally with status 0.
  bool wait() {
    if (!reaped_) {
      while (::waitpid(pid_, &status_, 0) < 0 && errno == EINTR) {
      }
      reaped_ = true;
    }
    return WIFEXITED(status_) && WEXITSTATUS(status_) == 0;
  }

 private:
  static constexpr std::uint64_t kMaxPayload = std::uint64_t{1} << 32;

  static void silence_child() {
    const int null = ::open("/dev/null", O_WRONLY);
    if (null >= 0) {
      ::dup2(null, STDOUT_FILENO);
      ::dup2(null, STDERR_FILENO);
    }
    const rlimit no_core{0, 0};
    ::setrlimit(RLIMIT_CORE, &no_core);
  }

  bool read_all(void* data, std::size_t size) {
    char* p = static_cast<char*>(data);
    while (size > 0) {
      const ssize_t n = ::read(fd_, p, size);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return false;
      p += n;
      size -= static_cast<std::size_t>(n);
    }
    return true;
  }

  pid_t pid_ = -1;
  int fd_ = -1;
  int status_ = 0;
  bool reaped_ = false;
};

}  // namespace palp
