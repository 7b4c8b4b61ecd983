#include "chart/chart.hpp"

#include <vtkAxis.h>
#include <vtkChartLegend.h>
#include <vtkChartXY.h>
#include <vtkContextScene.h>
#include <vtkContextView.h>
#include <vtkDoubleArray.h>
#include <vtkNew.h>
#include <vtkPNGWriter.h>
#include <vtkPen.h>
#include <vtkPlot.h>
#include <vtkPlotLine.h>
#include <vtkPlotPoints.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkTable.h>
#include <vtkTextProperty.h>
#include <vtkWindowToImageFilter.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <system_error>

#include "base/errors.hpp"

namespace palp::chart {
namespace {

// Marker shapes cycle once the palette has been used up, so series stay distinguishable.
constexpr std::array<int, 5> kMarkers{vtkPlotPoints::CIRCLE, vtkPlotPoints::SQUARE,
                                      vtkPlotPoints::DIAMOND, vtkPlotPoints::CROSS,
                                      vtkPlotPoints::PLUS};

bool keep_point(double x, double y, const ChartSpec& spec) {
  if (!std::isfinite(x) || !std::isfinite(y)) return false;
  if (spec.log_x && !(x > 0.0)) return false;
  if (spec.log_y && !(y > 0.0)) return false;
  return true;
}

// Titles, fonts and a range padded by 4 % of the span on each side (by a factor on a log axis),
// so points at the extremes are drawn whole.
void style_axis(vtkAxis* axis, const std::string& title, bool log, double lo, double hi,
                std::optional<double> fixed_lo, std::optional<double> fixed_hi) {
  axis->SetTitle(title);
  axis->GetTitleProperties()->SetFontSize(16);
  axis->GetTitleProperties()->BoldOff();
  axis->GetLabelProperties()->SetFontSize(13);
  axis->SetLogScale(log);
  if (!(lo <= hi)) {
    axis->SetBehavior(vtkAxis::AUTO);
    return;
  }
  if (log) {
    const double f = lo < hi ? std::pow(hi / lo, 0.04) : 1.5;
    lo /= f;
    hi *= f;
  } else {
    const double pad = lo < hi ? 0.04 * (hi - lo) : (lo != 0.0 ? 0.1 * std::fabs(lo) : 1.0);
    lo -= pad;
    hi += pad;
  }
  if (fixed_lo && (!log || *fixed_lo > 0.0)) lo = *fixed_lo;
  if (fixed_hi && (!log || *fixed_hi > 0.0)) hi = *fixed_hi;
  if (!(lo < hi)) hi = lo + 1.0;
  axis->SetUnscaledRange(lo, hi);
  axis->SetBehavior(vtkAxis::FIXED);
}

void validate(const ChartSpec& spec) {
  if (spec.width < 16 || spec.height < 16 || spec.width > 8192 || spec.height > 8192)
    throw UsageError("chart size must be between 16 and 8192 pixels a side (got " +
                     std::to_string(spec.width) + "x" + std::to_string(spec.height) + ")");
  if (spec.series.empty()) throw UsageError("chart '" + spec.title + "' has no series");
  std::size_t usable = 0;
  for (const Series& s : spec.series) {
    if (s.x.size() != s.y.size())
      throw UsageError("chart series '" + s.name + "' has " + std::to_string(s.x.size()) +
                       " x values but " + std::to_string(s.y.size()) + " y values");
    for (std::size_t i = 0; i < s.x.size(); ++i) usable += keep_point(s.x[i], s.y[i], spec);
  }
  if (usable == 0)
    throw UsageError("chart '" + spec.title + "' has no point to draw" +
                     ((spec.log_x || spec.log_y) ? " (log axes need positive values)" : ""));
}

}  // namespace

Color palette(std::size_t index) {
  // A ten-colour qualitative palette with good contrast on white.
  static constexpr std::array<Color, 10> kPalette{{{31, 119, 180},
                                                   {214, 39, 40},
                                                   {44, 160, 44},
                                                   {255, 127, 14},
                                                   {148, 103, 189},
                                                   {140, 86, 75},
                                                   {227, 119, 194},
                                                   {127, 127, 127},
                                                   {188, 189, 34},
                                                   {23, 190, 207}}};
  return kPalette[index % kPalette.size()];
}

bool display_available() {
  const char* d = std::getenv("DISPLAY");
  return d != nullptr && *d != '\0';
}

std::string no_display_message(std::string_view program) {
  return std::string(program) +
         ": no X display (DISPLAY is not set); VTK renders through X even off screen. Run it "
         "under a virtual display: xvfb-run -a " +
         std::string(program) + " ...";
}

namespace {

// The axes' titles, scales and ranges, from the points the chart keeps.
void style_axes(vtkChartXY* chart, const ChartSpec& spec) {
  double x_lo = std::numeric_limits<double>::infinity(), x_hi = -x_lo, y_lo = x_lo, y_hi = -x_lo;
  for (const Series& s : spec.series)
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!keep_point(s.x[i], s.y[i], spec)) continue;
      x_lo = std::min(x_lo, s.x[i]);
      x_hi = std::max(x_hi, s.x[i]);
      y_lo = std::min(y_lo, s.y[i]);
      y_hi = std::max(y_hi, s.y[i]);
    }
  style_axis(chart->GetAxis(vtkAxis::BOTTOM), spec.x_title, spec.log_x, x_lo, x_hi, spec.x_min,
             spec.x_max);
  style_axis(chart->GetAxis(vtkAxis::LEFT), spec.y_title, spec.log_y, y_lo, y_hi, spec.y_min,
             spec.y_max);
}

// The legend, shown or not, in its corner.
void place_legend(vtkChartXY* chart, const ChartSpec& spec) {
  chart->SetShowLegend(spec.legend);
  if (!spec.legend) return;
  vtkChartLegend* legend = chart->GetLegend();
  legend->SetLabelSize(13);
  const bool right = spec.legend_corner == LegendCorner::TopRight ||
                     spec.legend_corner == LegendCorner::BottomRight;
  const bool top =
      spec.legend_corner == LegendCorner::TopRight || spec.legend_corner == LegendCorner::TopLeft;
  legend->SetHorizontalAlignment(right ? vtkChartLegend::RIGHT : vtkChartLegend::LEFT);
  legend->SetVerticalAlignment(top ? vtkChartLegend::TOP : vtkChartLegend::BOTTOM);
}

// One series as a plot of the chart (none when no point is kept); `plain_index` counts the
// series that are not highlighted, for their colours and markers.
void add_plot(vtkChartXY* chart, const ChartSpec& spec, const Series& s, std::size_t& plain_index) {
  vtkNew<vtkTable> table;
  vtkNew<vtkDoubleArray> xs, ys;
  xs->SetName("x");
  ys->SetName(s.name.empty() ? "y" : s.name.c_str());
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!keep_point(s.x[i], s.y[i], spec)) continue;
    xs->InsertNextValue(s.x[i]);
    ys->InsertNextValue(s.y[i]);
  }
  if (xs->GetNumberOfTuples() == 0) return;
  table->AddColumn(xs);
  table->AddColumn(ys);

  const bool line = s.style != Style::Points;
  vtkPlot* plot = chart->AddPlot(line ? vtkChart::LINE : vtkChart::POINTS);
  plot->SetInputData(table, 0, 1);
  plot->SetLabel(s.name);
  const std::size_t index = s.highlight ? 0 : plain_index++;
  const Color c = s.color ? *s.color : (s.highlight ? Color{0, 0, 0} : palette(index));
  plot->SetColor(c.r, c.g, c.b, 255);
  plot->SetWidth(s.style == Style::Points ? 1.0f : s.line_width);
  if (auto* points = vtkPlotPoints::SafeDownCast(plot)) {
    const int marker = s.highlight ? vtkPlotPoints::DIAMOND : kMarkers[(index / 10) % 5];
    points->SetMarkerStyle(s.style == Style::Line ? vtkPlotPoints::NONE : marker);
    points->SetMarkerSize(s.highlight ? s.marker_size * 1.6f : s.marker_size);
  }
}

// The rendered window as a PNG, written under a temporary name and renamed, so a failed write
// leaves no partial PNG.
void write_png(vtkRenderWindow* window, const std::string& path) {
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();
  grab->Update();

  const std::string tmp = path + ".tmp.png";
  vtkNew<vtkPNGWriter> writer;
  writer->SetFileName(tmp.c_str());
  writer->SetInputConnection(grab->GetOutputPort());
  writer->Write();
  std::error_code ec;
  if (writer->GetErrorCode() != 0 || std::filesystem::file_size(tmp, ec) == 0 || ec) {
    std::filesystem::remove(tmp, ec);
    throw InputError("cannot write chart PNG '" + path + "'");
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw InputError("cannot write chart PNG '" + path + "': " + ec.message());
  }
}

}  // namespace

void render_png(const ChartSpec& spec, const std::string& path) {
  validate(spec);
  if (!display_available()) throw ResourceError(no_display_message("chart"));

  vtkNew<vtkContextView> view;
  vtkRenderWindow* window = view->GetRenderWindow();
  window->SetOffScreenRendering(1);
  window->SetSize(spec.width, spec.height);
  window->SetMultiSamples(0);
  view->GetRenderer()->SetBackground(1.0, 1.0, 1.0);

  vtkNew<vtkChartXY> chart;
  view->GetScene()->AddItem(chart);
  chart->SetTitle(spec.title);
  chart->GetTitleProperties()->SetFontSize(18);
  chart->GetTitleProperties()->BoldOn();
  style_axes(chart, spec);
  place_legend(chart, spec);

  // Highlighted series go last so they sit on top.
  std::size_t plain_index = 0;
  for (const Series& s : spec.series)
    if (!s.highlight) add_plot(chart, spec, s, plain_index);
  for (const Series& s : spec.series)
    if (s.highlight) add_plot(chart, spec, s, plain_index);

  window->Render();
  write_png(window, path);
}

// ---------------------------------------------------------------------------------------------
// CSV

std::size_t Table::column(std::string_view name) const {
  for (std::size_t i = 0; i < columns.size(); ++i)
    if (columns[i] == name) return i;
  std::string known;
  for (const std::string& c : columns) known += (known.empty() ? "" : ", ") + c;
  throw UsageError("no column '" + std::string(name) + "' (columns: " + known + ")");
}

std::vector<double> Table::numbers(std::string_view name) const {
  const std::size_t c = column(name);
  std::vector<double> out;
  out.reserve(rows.size());
  for (const auto& row : rows) {
    const std::string& f = row[c];
    double v = std::numeric_limits<double>::quiet_NaN();
    const char* b = f.data();
    const char* e = f.data() + f.size();
    while (b < e && *b == ' ') ++b;
    if (b < e && *b == '+') ++b;
    const auto r = std::from_chars(b, e, v);
    if (r.ec != std::errc() || r.ptr != e) v = std::numeric_limits<double>::quiet_NaN();
    out.push_back(v);
  }
  return out;
}

Table parse_csv(std::string_view text, const std::string& what) {
  Table t;
  std::size_t pos = 0, line_no = 0;
  while (pos < text.size()) {
    // One record (quoted fields may span lines).
    std::vector<std::string> fields;
    std::string field;
    bool quoted = false, any = false;
    ++line_no;
    const std::size_t record_line = line_no;
    for (; pos < text.size(); ++pos) {
      const char ch = text[pos];
      if (quoted) {
        if (ch == '"') {
          if (pos + 1 < text.size() && text[pos + 1] == '"') {
            field += '"';
            ++pos;
          } else {
            quoted = false;
          }
        } else {
          if (ch == '\n') ++line_no;
          field += ch;
        }
        continue;
      }
      if (ch == '"') {
        quoted = true;
        any = true;
      } else if (ch == ',') {
        fields.push_back(std::move(field));
        field.clear();
        any = true;
      } else if (ch == '\n') {
        ++pos;
        break;
      } else if (ch != '\r') {
        field += ch;
        any = true;
      }
    }
    if (quoted)
      throw InputError(what + ": unterminated quote in line " + std::to_string(record_line));
    if (!any) continue;  // blank line
    fields.push_back(std::move(field));
    if (t.columns.empty()) {
      t.columns = std::move(fields);
      continue;
    }
    if (fields.size() != t.columns.size())
      throw InputError(what + ": line " + std::to_string(record_line) + " has " +
                       std::to_string(fields.size()) + " fields, the header has " +
                       std::to_string(t.columns.size()));
    t.rows.push_back(std::move(fields));
  }
  if (t.columns.empty()) throw InputError(what + ": no header row");
  return t;
}

Table read_csv(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot read CSV '" + path + "'");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw InputError("cannot read CSV '" + path + "'");
  return parse_csv(ss.str(), "CSV '" + path + "'");
}

std::vector<std::size_t> pareto_front(const std::vector<double>& x, const std::vector<double>& y) {
  const std::size_t n = std::min(x.size(), y.size());
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < n; ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) idx.push_back(i);
  // By x, then y, then first occurrence: a point is on the front when its y is below every y
  // seen before it.
  std::stable_sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) {
    return x[a] < x[b] || (x[a] == x[b] && y[a] < y[b]);
  });
  std::vector<std::size_t> front;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i : idx) {
    if (y[i] < best) {
      front.push_back(i);
      best = y[i];
    }
  }
  return front;
}

}  // namespace palp::chart
