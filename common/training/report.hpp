// A training session's record and its report (issue 40, docs/tasks.md "The report"): the task,
// its target, the landmarks it was resolved from, and the trials, each with its samples, marks
// and score. Writers: a self-contained HTML page (the charts inline as SVG images, so it opens
// from a recording's folder in any browser) and the cohort CSV a study appends one row per trial
// to. Everything user-provided (ids, scene, notes, landmark names) is escaped.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "anatomy/landmarks.hpp"
#include "training/task.hpp"

namespace palp::training {

struct Trial {
  int number = 1;  // 1-based, as shown
  std::vector<TrialSample> samples;
  std::vector<Mark> marks;
  TrialScore score;
};

struct Session {
  std::string id;       // the session's id (a recording's name, palp task --session)
  std::string trainee;  // empty when not given
  std::string scene;    // what the landmarks were found in
  std::string tool;     // "finger:7", empty when unknown
  TaskTarget target;
  anatomy::Landmarks landmarks;
  std::vector<Trial> trials;
};

// One trial's summary as the report's table and the cohort CSV show it: the last mark is the
// trial's answer (where, in_target, distance_mm), best_distance_mm the nearest of its marks.
struct TrialSummary {
  std::size_t marks = 0;
  std::string where;  // empty without marks
  std::optional<bool> in_target;
  std::optional<double> distance_mm, best_distance_mm, time_to_mark_s;
};
TrialSummary summarize(const Trial& trial);

// The charts, as SVG documents: the normal force over time with the marks as vertical lines, and
// the path of the skin point (in contact) over the patient's skin in the task's view (task_view:
// seen from the target's normal, superior up), with the target, its anatomy (the side's ribs
// as bands kRibHalfWidthMm wide, the spinous tips and interspaces, the pulse's radius) and the
// marks numbered in order.
std::string force_chart_svg(const Trial& trial);
std::string path_chart_svg(const Session& session, const Trial& trial);

// The report page: the task and target, the notes, per trial the two charts and its marks, and
// the table of metrics (one row per trial). The page sets data-images-loaded="yes" on <body>
// once every image has decoded (what a headless browser test checks).
std::string report_html(const Session& session);

// DIR/report.html, written under a temporary name and renamed; DIR is created when missing.
// Returns the page's path.
std::string write_report(const std::string& dir, const Session& session);

}  // namespace palp::training
