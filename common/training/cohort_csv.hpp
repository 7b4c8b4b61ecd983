// The cohort CSV a study appends one row per trial to (docs/tasks.md "The cohort CSV"): every
// session of every trainee in one table, appended safely by concurrent writers.
#pragma once

#include <string>

#include "training/report.hpp"

namespace palp::training {

// The cohort CSV's columns, in order (stable: studies concatenate files across versions).
extern const char* const kCohortCsvHeader;  // without the line break
// One row per trial (with '\n'): session, trainee, task, scene, trial, marks, where, in_target,
// distance_mm (the last mark's: the trial's answer), best_distance_mm, time_to_mark_s,
// peak_force_n, mean_force_n, path_length_mm, time_in_contact_s, duration_s. Empty cells where
// a trial has no mark. Text cells are quoted when they hold a comma, quote or line break, and
// prefixed with ' when they start like a spreadsheet formula (=, +, -, @).
std::string cohort_csv_rows(const Session& session);
// Appends the session's rows to `path`: under an exclusive lock (flock), the header first when
// the file is new or empty, all rows in one write; InputError when an existing file's first line
// is not kCohortCsvHeader (another table: never mix columns).
void append_cohort_csv(const std::string& path, const Session& session);

}  // namespace palp::training
