// Charts as PNG files: line and scatter charts drawn with VTK's chart module, rendered off screen.
//
// Debian's VTK renders through X even off screen, so a display is needed: without one (DISPLAY
// unset) render_png throws ResourceError before VTK is touched; run under `xvfb-run -a`.
// Reading CSV tables and finding Pareto fronts needs no display.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace palp::chart {

struct Color {
  unsigned char r = 0, g = 0, b = 0;
};

enum class Style { Line, Points, LinePoints };

struct Series {
  std::string name;
  std::vector<double> x, y;
  Style style = Style::LinePoints;
  std::optional<Color> color;  // default: the palette, in series order
  float line_width = 2.0f;
  float marker_size = 7.0f;
  bool highlight = false;  // drawn last, larger markers, black unless a color is given
};

enum class LegendCorner { TopRight, TopLeft, BottomRight, BottomLeft };

struct ChartSpec {
  std::string title;
  std::string x_title, y_title;
  bool log_x = false, log_y = false;
  // Axis ranges; unset ends follow the data (padded by 4 % of the span).
  std::optional<double> x_min, x_max, y_min, y_max;
  int width = 900, height = 600;  // pixels
  bool legend = true;
  LegendCorner legend_corner = LegendCorner::TopRight;
  std::vector<Series> series;
};

// Series colours in order (a qualitative palette readable on white).
Color palette(std::size_t index);

// True when an X display is named (DISPLAY set and not empty).
bool display_available();

// The one-line message for a missing display, suggesting xvfb-run.
std::string no_display_message(std::string_view program);

// Renders the chart off screen and writes it as PNG. Throws UsageError for an unusable spec
// (no series, mismatched x/y, size out of 16..8192, no finite point, a log axis without positive
// data), ResourceError without a display, InputError when the file cannot be written.
// Points that are not finite, or not positive on a log axis, are dropped.
void render_png(const ChartSpec& spec, const std::string& path);

// A CSV table with a header row. Fields are separated by commas; a field may be quoted with
// double quotes (a doubled quote inside stands for one). Blank lines are skipped.
struct Table {
  std::vector<std::string> columns;
  std::vector<std::vector<std::string>> rows;  // every row has columns.size() fields

  // Index of a column; UsageError naming the known columns when absent.
  std::size_t column(std::string_view name) const;
  // A column's values as numbers (NaN where a field is not a number).
  std::vector<double> numbers(std::string_view name) const;
};

// InputError when the file cannot be read or a row has the wrong number of fields.
Table read_csv(const std::string& path);
Table parse_csv(std::string_view text, const std::string& what = "CSV");

// Indices of the points not dominated by any other when both x and y are to be minimised,
// ordered by increasing x. Non-finite points are ignored; of identical points the first counts.
std::vector<std::size_t> pareto_front(const std::vector<double>& x, const std::vector<double>& y);

}  // namespace palp::chart
