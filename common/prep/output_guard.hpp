// What an unfinished prep leaves behind: nothing of its own. A PrepOutputGuard lives for one
// run_prep; unless committed, it removes from the output directory the temporary files of the
// outputs (NAME.partial*, NAME.tmp-*: prep's and the writers' names before the rename) and, when
// this run created the directory, the outputs themselves and the directories it created (each
// only if then empty; another file in them stays). The same cleanup runs from SIGINT / SIGTERM
// once install_prep_interrupt_cleanup() has been called (palp prep does): the handler uses only
// open, getdents64, unlinkat, rmdir, pthread_kill and raise, then the signal's default action ends
// the process.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace palp {

class PrepOutputGuard {
 public:
  // Notes which of dir and its parents do not exist yet: construct before creating dir. names:
  // the outputs' file names inside dir. Guards may live in several threads at once; the signal
  // handler cleans up after the first of those alive (its paths are kept in fixed storage).
  PrepOutputGuard(const std::filesystem::path& dir, const std::vector<std::string>& names);
  ~PrepOutputGuard();
  PrepOutputGuard(const PrepOutputGuard&) = delete;
  PrepOutputGuard& operator=(const PrepOutputGuard&) = delete;

  // More outputs, named once known (the structures of a label map). Safe while a signal may
  // arrive: the handler sees each name whole or not at all. Error beyond 528 names in all.
  void add_names(const std::vector<std::string>& names);

  // Prep finished (or found its result cached): nothing is removed.
  void commit();

  struct Paths;

 private:
  void release();

  std::unique_ptr<Paths> paths_;
  bool committed_ = false;
};

// SIGINT and SIGTERM clean up the running prep's guard before ending the process as they would
// have. Idempotent.
void install_prep_interrupt_cleanup();

}  // namespace palp
