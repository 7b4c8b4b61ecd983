// PrepOutputGuard (see output_guard.hpp). Each guard's paths live in fixed-size buffers filled
// before the guard is published (an atomic pointer), names added later each before the count that
// covers it (an atomic int), so the signal handler reads them without locks or allocation, and
// lists the directory with the raw getdents64 call (opendir may allocate). A signal that lands on a
// worker thread is forwarded to the thread running prep: the handler then interrupts the only
// thread that renames files, so no rename can follow the cleanup.
#include "prep/output_guard.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <system_error>

#include "base/errors.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;

// prep's own outputs and two files per labelled structure (a label map has at most 255).
constexpr int kMaxNames = 528;
constexpr int kMaxDirs = 16;
constexpr std::size_t kMaxPath = 4096;
constexpr std::size_t kMaxName = 256;

}  // namespace

struct PrepOutputGuard::Paths {
  char dir[kMaxPath];
  char names[kMaxNames][kMaxName];
  // Names added while the guard is published (add_names) are written before the count grows, so
  // the handler sees only whole names.
  std::atomic<int> names_count{0};
  char created_dirs[kMaxDirs][kMaxPath];  // the output directory first, then its new parents
  int created_dirs_count = 0;
  pthread_t owner;
};

namespace {

using Paths = PrepOutputGuard::Paths;

// The guard the signal handler cleans up after (null: none).
std::atomic<Paths*> g_active{nullptr};
static_assert(std::atomic<Paths*>::is_always_lock_free);
static_assert(std::atomic<int>::is_always_lock_free);

void copy_text(char* to, const std::string& from, std::size_t capacity) {
  if (from.size() >= capacity) throw Error(from + ": path too long for prep's output");
  std::memcpy(to, from.c_str(), from.size() + 1);
}

bool starts_with(const char* text, const char* prefix) {
  return std::strncmp(text, prefix, std::strlen(prefix)) == 0;
}

// Whether prep wrote the entry `name`: an output's temporary always, the output itself only in a
// directory this run created.
bool is_ours(const Paths& paths, const char* name) {
  const int count = paths.names_count.load(std::memory_order_acquire);
  for (int i = 0; i < count; ++i) {
    const char* output = paths.names[i];
    if (!starts_with(name, output)) continue;
    const char* rest = name + std::strlen(output);
    if (starts_with(rest, ".partial") || starts_with(rest, ".tmp-")) return true;
    if (*rest == '\0' && paths.created_dirs_count > 0) return true;
  }
  return false;
}

// Async-signal-safe: open, getdents64, unlinkat, close and rmdir only.
void remove_unfinished(const Paths& paths) {
  const int dir = ::open(paths.dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    alignas(8) char buffer[8192];
    // Entries removed during a listing may shift the rest: list again until nothing is ours.
    for (int pass = 0; pass < 8; ++pass) {
      bool removed = false;
      ::lseek(dir, 0, SEEK_SET);
      for (;;) {
        const long got = ::syscall(SYS_getdents64, dir, buffer, sizeof buffer);
        if (got <= 0) break;
        for (long at = 0; at < got;) {
          // struct linux_dirent64: ino (8), off (8), reclen (2), type (1), name
          unsigned short length;
          std::memcpy(&length, buffer + at + 16, sizeof length);
          const char* name = buffer + at + 19;
          if (is_ours(paths, name) && ::unlinkat(dir, name, 0) == 0) removed = true;
          at += length;
        }
      }
      if (!removed) break;
    }
    ::close(dir);
  }
  for (int i = 0; i < paths.created_dirs_count; ++i) {
    if (::rmdir(paths.created_dirs[i]) != 0) break;  // not empty: what is above stays too
  }
}

extern "C" void on_interrupt(int signal_number) {
  const Paths* active = g_active.load();
  if (active && !pthread_equal(pthread_self(), active->owner)) {
    pthread_kill(active->owner, signal_number);
    return;
  }
  if (const Paths* paths = g_active.exchange(nullptr)) remove_unfinished(*paths);
  struct sigaction action {};
  action.sa_handler = SIG_DFL;
  sigemptyset(&action.sa_mask);
  sigaction(signal_number, &action, nullptr);
  raise(signal_number);
}

}  // namespace

PrepOutputGuard::PrepOutputGuard(const fs::path& dir, const std::vector<std::string>& names)
    : paths_(std::make_unique<Paths>()) {
  Paths& paths = *paths_;
  std::error_code ec;
  fs::path start = fs::absolute(dir, ec).lexically_normal();
  if (ec) start = dir;
  if (!start.has_filename()) start = start.parent_path();  // "out/" names out
  copy_text(paths.dir, start.string(), kMaxPath);
  for (fs::path p = start; !p.empty() && paths.created_dirs_count < kMaxDirs; p = p.parent_path()) {
    if (fs::exists(p, ec) || p == p.parent_path()) break;
    copy_text(paths.created_dirs[paths.created_dirs_count++], p.string(), kMaxPath);
  }
  add_names(names);
  paths.owner = pthread_self();
  Paths* none = nullptr;
  g_active.compare_exchange_strong(none, paths_.get());
}

PrepOutputGuard::~PrepOutputGuard() {
  release();
  if (!committed_) remove_unfinished(*paths_);
}

void PrepOutputGuard::add_names(const std::vector<std::string>& names) {
  Paths& paths = *paths_;
  int count = paths.names_count.load(std::memory_order_relaxed);
  if (names.size() > static_cast<std::size_t>(kMaxNames - count))
    throw Error("prep output guard: too many outputs");
  for (const auto& name : names) {
    copy_text(paths.names[count], name, kMaxName);
    paths.names_count.store(++count, std::memory_order_release);
  }
}

void PrepOutputGuard::release() {
  Paths* mine = paths_.get();
  g_active.compare_exchange_strong(mine, nullptr);
}

void PrepOutputGuard::commit() {
  committed_ = true;
  release();
}

void install_prep_interrupt_cleanup() {
  struct sigaction action {};
  action.sa_handler = on_interrupt;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

}  // namespace palp
