// The marks file of `palp task --marks` (docs/tasks.md "The marks file") and the split of one
// recorded run into trials by its marks.
//
// CSV, one mark a row, after a header naming the columns: `t` (s, on the trajectory's clock:
// its `t` column) is required; `trial` (1, 2, ...) is optional, every mark in trial 1 without
// it. Other columns (a note, who marked) are ignored; blank lines are skipped; "\r\n" accepted.
// Trials are numbered from 1 without gaps, in file order; times never decrease. At most
// kMaxTrialMarks marks in a file and kMaxMarksFileBytes bytes. Errors name the file and line.
//
// Trials: trial k runs from the row after trial k-1's last mark (the first row for trial 1) to
// its own last mark's row; the last trial runs to the end of the run. Sample and mark times in a
// trial count from its first row.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "training/report.hpp"

namespace palp::training {

struct MarkRow {
  int trial = 1;
  double t = 0.0;  // s, the run's clock
};

inline constexpr std::uintmax_t kMaxMarksFileBytes = std::uintmax_t{1} << 20;

std::vector<MarkRow> parse_marks_csv(std::string_view text, const std::string& name);
std::vector<MarkRow> read_marks_csv(const std::string& path);

// The file for `marks`: header `trial,t`, one row a mark, each time in the shortest text that
// reads back to the same double (so a trajectory's row time matches exactly).
std::string format_marks_csv(const std::vector<MarkRow>& marks);
// Writes it through a renamed partial file (Error when it cannot be written).
void write_marks_csv(const std::string& path, const std::vector<MarkRow>& marks);

// The trials of a run: `samples` on the run's clock (in time order), `marks` as read. Each
// trial's samples and marks (placed with mark_at) are rebased to its first row; scores are left
// empty for score_trial. InputError for a mark outside the run or a trial without rows.
std::vector<Trial> split_trials(const std::vector<TrialSample>& samples,
                                const std::vector<MarkRow>& marks);

}  // namespace palp::training
