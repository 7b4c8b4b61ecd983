// A session's report page and cohort CSV (report.hpp).
//   Session -> per trial: metrics row + force chart + path chart (report_charts.cpp)
//           -> report.html (charts inline as SVG data URIs) | cohort CSV rows (appended, locked)
#include "training/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>

#include "base/errors.hpp"
#include "base/file_replace.hpp"
#include "training/svg.hpp"

namespace palp::training {
namespace {

namespace fs = std::filesystem;

std::string maybe(const std::optional<double>& v, int decimals, const char* none) {
  return v ? fixed(*v, decimals) : std::string(none);
}

std::string point_text(const Vec3d& p) {
  std::string text = "(";
  text += fixed(p.x, 1);
  text += ", ";
  text += fixed(p.y, 1);
  text += ", ";
  text += fixed(p.z, 1);
  return text + ")";
}

constexpr const char* kStyle = R"(<style>
body { font-family: sans-serif; margin: 24px; color: #222; }
table { border-collapse: collapse; margin: 8px 0 16px; }
th, td { border: 1px solid #bbb; padding: 3px 8px; text-align: right; }
th { background: #f0f0f0; } td.text { text-align: left; }
.hit { color: #1a9850; font-weight: bold; } .miss { color: #d73027; }
img.chart { border: 1px solid #ddd; margin: 4px 8px 4px 0; vertical-align: top; }
.notes { color: #8a5a00; }
</style>
)";

// Sets data-images-loaded on <body>: "yes" once every image has decoded with a width.
constexpr const char* kImagesScript = R"(<script>
(function () {
  function check() {
    var images = document.images, ok = images.length > 0;
    for (var i = 0; i < images.length; i++)
      if (!images[i].complete || images[i].naturalWidth === 0) ok = false;
    document.body.setAttribute('data-images-loaded', ok ? 'yes' : 'no');
    document.body.setAttribute('data-images', String(images.length));
  }
  for (var i = 0; i < document.images.length; i++) {
    document.images[i].addEventListener('load', check);
    document.images[i].addEventListener('error', check);
  }
  window.addEventListener('load', check);
  check();
})();
</script>
)";

std::string header_section(const Session& s) {
  const TaskTarget& t = s.target;
  std::string html = "<h1>palp task: " + xml_escape(describe(t.spec)) + "</h1>\n<p>";
  html += "session <b id=\"session\">" + xml_escape(s.id) + "</b>";
  if (!s.trainee.empty()) html += ", trainee <b id=\"trainee\">" + xml_escape(s.trainee) + "</b>";
  html += "<br>scene " + xml_escape(s.scene);
  if (!s.tool.empty()) html += ", tool " + xml_escape(s.tool);
  html += "<br>target at " + point_text(t.point) + " mm, skin normal " + point_text(t.normal) +
          " (patient LPS)";
  if (t.spec.kind == TaskKind::femoral)
    html += ", on the pulse within " + fixed(t.radius_mm, 1) + " mm" +
            (t.pulse_felt ? "" : " (no pulse in this scan)");
  html += "</p>\n";
  std::vector<std::string> notes = t.notes;
  notes.insert(notes.end(), s.landmarks.notes.begin(), s.landmarks.notes.end());
  if (!notes.empty()) {
    html += "<ul class=\"notes\">\n";
    for (const std::string& note : notes) html += "<li>" + xml_escape(note) + "</li>\n";
    html += "</ul>\n";
  }
  return html;
}

std::string metrics_table(const Session& s) {
  std::string html =
      "<h2>Metrics</h2>\n<table id=\"metrics\">\n<tr><th>trial</th><th>marks</th>"
      "<th>where (last mark)</th><th>in target</th><th>distance (mm)</th><th>best (mm)</th>"
      "<th>time to mark (s)</th><th>peak force (N)</th><th>mean force (N)</th>"
      "<th>path (mm)</th><th>in contact (s)</th><th>duration (s)</th></tr>\n";
  for (const Trial& trial : s.trials) {
    const TrialSummary r = summarize(trial);
    const TrialScore& sc = trial.score;
    const char* hit = !r.in_target ? "" : *r.in_target ? " class=\"hit\"" : " class=\"miss\"";
    html += "<tr data-trial=\"" + std::to_string(trial.number) + "\"><td>" +
            std::to_string(trial.number) + "</td><td>" + std::to_string(r.marks) +
            "</td><td class=\"text\">" + xml_escape(r.where.empty() ? "-" : r.where) + "</td><td" +
            hit + ">" +
            (!r.in_target   ? "-"
             : *r.in_target ? "yes"
                            : "no") +
            "</td><td>" + maybe(r.distance_mm, 1, "-") + "</td><td>" +
            maybe(r.best_distance_mm, 1, "-") + "</td><td>" + maybe(r.time_to_mark_s, 2, "-") +
            "</td><td>" + fixed(sc.peak_force_n, 2) + "</td><td>" + fixed(sc.mean_force_n, 2) +
            "</td><td>" + fixed(sc.path_length_mm, 1) + "</td><td>" +
            fixed(sc.time_in_contact_s, 2) + "</td><td>" + fixed(sc.duration_s, 2) + "</td></tr>\n";
  }
  return html + "</table>\n";
}

std::string trial_section(const Session& s, const Trial& trial) {
  const std::string n = std::to_string(trial.number);
  std::string html = "<h2>Trial " + n + "</h2>\n";
  html += "<img class=\"chart\" alt=\"normal force over time, trial " + n + "\" src=\"" +
          svg_data_uri(force_chart_svg(trial)) + "\">\n";
  html += "<img class=\"chart\" alt=\"path over the skin, trial " + n + "\" src=\"" +
          svg_data_uri(path_chart_svg(s, trial)) + "\">\n";
  if (trial.score.marks.empty()) return html + "<p>no mark</p>\n";
  html +=
      "<table class=\"marks\">\n<tr><th>mark</th><th>t (s)</th><th>where</th>"
      "<th>distance (mm)</th><th>point (LPS mm)</th></tr>\n";
  for (std::size_t i = 0; i < trial.score.marks.size(); ++i) {
    const MarkScore& m = trial.score.marks[i];
    html += "<tr><td>" + std::to_string(i + 1) + "</td><td>" + fixed(m.mark.t, 3) +
            "</td><td class=\"text " + (m.in_target ? "hit" : "miss") + "\">" +
            xml_escape(m.where) + "</td><td>" + fixed(m.distance_mm, 1) + "</td><td>" +
            point_text(m.mark.point) + "</td></tr>\n";
  }
  return html + "</table>\n";
}

}  // namespace

TrialSummary summarize(const Trial& trial) {
  TrialSummary row;
  const auto& marks = trial.score.marks;
  row.marks = marks.size();
  row.time_to_mark_s = trial.score.time_to_first_mark_s;
  if (marks.empty()) return row;
  row.where = marks.back().where;
  row.in_target = marks.back().in_target;
  row.distance_mm = marks.back().distance_mm;
  double best = marks.front().distance_mm;
  for (const MarkScore& m : marks) best = std::min(best, m.distance_mm);
  row.best_distance_mm = best;
  return row;
}

std::string report_html(const Session& session) {
  std::string html = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  html += "<title>palp task " + xml_escape(describe(session.target.spec)) + " - " +
          xml_escape(session.id) + "</title>\n" + kStyle + "</head>\n";
  html += "<body data-images-loaded=\"no\">\n" + header_section(session) + metrics_table(session);
  for (const Trial& trial : session.trials) html += trial_section(session, trial);
  return html + kImagesScript + "</body>\n</html>\n";
}

std::string write_report(const std::string& dir, const Session& session) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error(dir + ": cannot create the report's directory: " + ec.message());
  const std::string path = (fs::path(dir) / "report.html").string();
  replace_file(path, report_html(session));
  return path;
}

}  // namespace palp::training
