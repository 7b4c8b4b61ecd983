// The marks file and the split of a run into trials (marks_file.hpp).
//   text -> header (t, trial columns) -> rows (trial, t) checked -> per trial: rows, marks
#include "training/marks_file.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "base/errors.hpp"
#include "base/file_replace.hpp"

namespace palp::training {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> cells;
  for (std::size_t start = 0;;) {
    const auto comma = line.find(',', start);
    cells.push_back(trim(line.substr(start, comma - start)));
    if (comma == std::string_view::npos) return cells;
    start = comma + 1;
  }
}

template <class T>
bool parse_number(std::string_view cell, T& out) {
  const auto [end, ec] = std::from_chars(cell.data(), cell.data() + cell.size(), out);
  return ec == std::errc() && end == cell.data() + cell.size();
}

// Where the header puts t and trial (-1: absent).
struct Columns {
  int t = -1, trial = -1;
  std::size_t count = 0;
};

Columns header_columns(std::string_view line, const std::string& where) {
  Columns c;
  const auto cells = split(line);
  c.count = cells.size();
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (cells[i] == "t") c.t = static_cast<int>(i);
    if (cells[i] == "trial") c.trial = static_cast<int>(i);
  }
  if (c.t < 0) throw InputError(where + ": the header has no column t (marks: t[,trial])");
  return c;
}

MarkRow parse_row(std::string_view line, const Columns& c, const std::string& where) {
  const auto cells = split(line);
  if (cells.size() != c.count)
    throw InputError(where + ": " + std::to_string(cells.size()) + " cells, the header has " +
                     std::to_string(c.count));
  MarkRow row;
  if (!parse_number(cells[c.t], row.t) || !std::isfinite(row.t))
    throw InputError(where + ": t is not a number: '" + std::string(cells[c.t]) + "'");
  if (c.trial >= 0 && (!parse_number(cells[c.trial], row.trial) || row.trial < 1))
    throw InputError(where + ": trial is not a number from 1: '" + std::string(cells[c.trial]) +
                     "'");
  return row;
}

}  // namespace

std::string format_marks_csv(const std::vector<MarkRow>& marks) {
  std::string text = "trial,t\n";
  for (const MarkRow& m : marks) {
    char number[32];
    const auto end = std::to_chars(number, number + sizeof number, m.t).ptr;
    text += std::to_string(m.trial) + "," + std::string(number, end) + "\n";
  }
  return text;
}

void write_marks_csv(const std::string& path, const std::vector<MarkRow>& marks) {
  replace_file(path, format_marks_csv(marks));
}

std::vector<MarkRow> parse_marks_csv(std::string_view text, const std::string& name) {
  std::vector<MarkRow> rows;
  std::optional<Columns> columns;
  std::size_t line_number = 0;
  for (std::size_t start = 0; start < text.size();) {
    const auto nl = text.find('\n', start);
    const std::string_view line =
        trim(text.substr(start, nl == std::string_view::npos ? nl : nl - start));
    start = nl == std::string_view::npos ? text.size() : nl + 1;
    ++line_number;
    if (line.empty()) continue;
    const std::string where = name + ":" + std::to_string(line_number);
    if (!columns) {
      columns = header_columns(line, where);
      continue;
    }
    const MarkRow row = parse_row(line, *columns, where);
    if (!rows.empty() && row.t < rows.back().t) throw InputError(where + ": marks go back in time");
    const int last_trial = rows.empty() ? 0 : rows.back().trial;
    if (row.trial != last_trial && row.trial != last_trial + 1)
      throw InputError(where + ": trial " + std::to_string(row.trial) + " after trial " +
                       std::to_string(last_trial) + " (trials count up from 1 without gaps)");
    if (rows.size() >= kMaxTrialMarks)
      throw InputError(name + ": more than " + std::to_string(kMaxTrialMarks) + " marks");
    rows.push_back(row);
  }
  if (!columns) throw InputError(name + ": empty (a marks file starts with the header t[,trial])");
  return rows;
}

std::vector<MarkRow> read_marks_csv(const std::string& path) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw InputError(path + ": cannot read the marks file: " + ec.message());
  if (size > kMaxMarksFileBytes)
    throw InputError(path + ": a marks file of " + std::to_string(size) + " bytes is more than " +
                     std::to_string(kMaxMarksFileBytes));
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  if (!in && !in.eof()) throw InputError(path + ": cannot read the marks file");
  return parse_marks_csv(text.str(), path);
}

std::vector<Trial> split_trials(const std::vector<TrialSample>& samples,
                                const std::vector<MarkRow>& marks) {
  if (samples.empty()) throw InputError("a run without samples has no trials");
  const double end_t = samples.back().t;
  for (const MarkRow& m : marks)
    if (m.t < samples.front().t || m.t > end_t)
      throw InputError("a mark at t = " + std::to_string(m.t) + " s lies outside the run (" +
                       std::to_string(samples.front().t) + " to " + std::to_string(end_t) + " s)");
  const int trials = marks.empty() ? 1 : marks.back().trial;
  std::vector<Trial> out;
  std::size_t first = 0;  // the trial's first row
  for (int k = 1; k <= trials; ++k) {
    std::vector<double> times;
    for (const MarkRow& m : marks)
      if (m.trial == k) times.push_back(m.t);
    // The trial's last row: its last mark's (the row at or before it), or the run's last.
    std::size_t last = samples.size() - 1;
    if (k < trials) {
      const auto after = std::upper_bound(samples.begin(), samples.end(), times.back(),
                                          [](double t, const TrialSample& s) { return t < s.t; });
      last = static_cast<std::size_t>(after - samples.begin()) - 1;
    }
    if (first >= samples.size() || last < first)
      throw InputError("trial " + std::to_string(k) + " has no rows of the run");
    Trial trial;
    trial.number = k;
    const double t0 = samples[first].t;
    trial.samples.assign(samples.begin() + static_cast<std::ptrdiff_t>(first),
                         samples.begin() + static_cast<std::ptrdiff_t>(last) + 1);
    for (TrialSample& s : trial.samples) s.t -= t0;
    for (const double t : times) trial.marks.push_back(mark_at(trial.samples, t - t0));
    out.push_back(std::move(trial));
    first = last + 1;
  }
  return out;
}

}  // namespace palp::training
