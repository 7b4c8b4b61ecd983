// The cohort CSV (cohort_csv.hpp): rows from a session's trials, appended under a lock.
//   Session -> summarize each trial -> one row each -> flock -> [header if new] + rows -> write
#include "training/cohort_csv.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string_view>

#include "base/errors.hpp"

namespace palp::training {
namespace {

// A text cell: formula-like starts neutralized, quoted when it holds a separator.
std::string text_cell(const std::string& text) {
  std::string cell;
  if (!text.empty() && std::string_view("=+-@").find(text[0]) != std::string_view::npos)
    cell += '\'';
  cell += text;
  if (cell.find_first_of(",\"\r\n") == std::string::npos) return cell;
  std::string quoted = "\"";
  for (const char c : cell) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}

std::string number_cell(double v) {
  if (!std::isfinite(v)) return "";
  char text[48];
  std::snprintf(text, sizeof text, "%.3f", v);
  return text;
}

std::string number_cell(const std::optional<double>& v) {
  return v ? number_cell(*v) : std::string();
}

// Writes all of `text` to `fd` (O_APPEND: every write lands at the end).
void write_all(int fd, const std::string& text, const std::string& path) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw Error(path + ": cannot append: " + std::strerror(errno));
    done += static_cast<std::size_t>(n);
  }
}

// The file's first line (up to the header's length and one more byte), read under the lock.
std::string first_line(int fd) {
  std::string line(std::strlen(kCohortCsvHeader) + 1, '\0');
  const ssize_t n = ::pread(fd, line.data(), line.size(), 0);
  line.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
  return line;
}

// Closes the descriptor (and with it the lock) on every way out.
struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

const char* const kCohortCsvHeader =
    "session,trainee,task,scene,trial,marks,where,in_target,distance_mm,best_distance_mm,"
    "time_to_mark_s,peak_force_n,mean_force_n,path_length_mm,time_in_contact_s,duration_s";

std::string cohort_csv_rows(const Session& session) {
  std::string rows;
  for (const Trial& trial : session.trials) {
    const TrialSummary r = summarize(trial);
    const TrialScore& s = trial.score;
    rows += text_cell(session.id) + "," + text_cell(session.trainee) + "," +
            text_cell(describe(session.target.spec)) + "," + text_cell(session.scene) + "," +
            std::to_string(trial.number) + "," + std::to_string(r.marks) + "," +
            text_cell(r.where) + "," +
            (!r.in_target   ? ""
             : *r.in_target ? "1"
                            : "0") +
            "," + number_cell(r.distance_mm) + "," + number_cell(r.best_distance_mm) + "," +
            number_cell(r.time_to_mark_s) + "," + number_cell(s.peak_force_n) + "," +
            number_cell(s.mean_force_n) + "," + number_cell(s.path_length_mm) + "," +
            number_cell(s.time_in_contact_s) + "," + number_cell(s.duration_s) + "\n";
  }
  return rows;
}

void append_cohort_csv(const std::string& path, const Session& session) {
  const std::string rows = cohort_csv_rows(session);
  Fd file{::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644)};
  if (file.fd < 0) throw Error(path + ": cannot open the cohort CSV: " + std::strerror(errno));
  while (::flock(file.fd, LOCK_EX) != 0)
    if (errno != EINTR) throw Error(path + ": cannot lock: " + std::strerror(errno));
  struct stat st {};
  if (::fstat(file.fd, &st) != 0) throw Error(path + ": cannot stat: " + std::strerror(errno));
  if (st.st_size > 0) {
    Fd reader{::open(path.c_str(), O_RDONLY | O_CLOEXEC)};
    const std::string line = reader.fd >= 0 ? first_line(reader.fd) : std::string();
    const std::string header = std::string(kCohortCsvHeader) + "\n";
    if (line != header)
      throw InputError(path + ": is not a palp cohort CSV (its first line is not the header " +
                       std::string(kCohortCsvHeader) + "); refusing to mix tables");
    write_all(file.fd, rows, path);
  } else {
    write_all(file.fd, std::string(kCohortCsvHeader) + "\n" + rows, path);
  }
  if (::fsync(file.fd) != 0) throw Error(path + ": cannot sync: " + std::strerror(errno));
}

}  // namespace palp::training
