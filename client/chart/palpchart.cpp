// palpchart — renders a line or scatter chart of CSV columns to a PNG file, off screen.
//
//   palpchart --csv FILE [--csv FILE...] --x COL --y COL[,COL...] --out FILE.png [options]
//
// VTK renders through X even off screen: without a display palpchart runs itself again under
// `xvfb-run -a` when that is installed, and otherwise says what to install. Exit status: 0
// written, 1 failure, 2 usage.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iostream>
#include <map>
#include <numeric>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <unistd.h>

#include "base/errors.hpp"
#include "chart/chart.hpp"
#include "chart/contact_sheet.hpp"

namespace {

using palp::UsageError;
namespace chart = palp::chart;

constexpr const char* kUsage =
    R"(usage: palpchart --csv FILE [--csv FILE...] --x COL --y COL[,COL...] --out FILE.png [options]

Draws the columns of CSV files (header row) as a line or scatter chart and writes a PNG. Several
--csv files are overlaid on one chart, each series named after its file (FILE's name without
.csv, then the series).
  --group COL[,COL...]  one series per distinct value (or combination) of these columns
  --where COL=V[|V...]  keep only rows whose COL equals one of the values (repeatable)
  --names A[,B...]      series names for the --y columns (default: the column names)
  --style S             line | points | linepoints (default linepoints)
  --mark COL            also draw the rows whose COL is non-zero as one highlighted series
  --pareto              highlight the Pareto front of (x, y), both minimised (one --y column)
  --mark-label TEXT     name of the highlighted series (default "Pareto front" or COL)
  --title TEXT          chart title
  --xlabel TEXT         x axis title (default: the x column)
  --ylabel TEXT         y axis title (default: the y column)
  --logx, --logy        logarithmic axes (rows with values <= 0 there are dropped)
  --xrange LO,HI        x axis range; either end may be empty to follow the data
  --yrange LO,HI        y axis range, likewise
  --size WxH            image size in pixels (default 900x600)
  --legend POS          tr | tl | br | bl | none (default tr)
Without an X display palpchart runs itself under xvfb-run -a (package xvfb) when it can.

usage: palpchart --sheet OUT.png [--columns N] IN.png...
  --sheet OUT.png       a contact sheet: the IN.png images in a grid, one PNG (no display needed)
  --columns N           images a row (default 3)
)";

std::vector<std::string> split(std::string_view s, char sep) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t p = s.find(sep, start);
    out.emplace_back(s.substr(start, p == std::string_view::npos ? s.npos : p - start));
    if (p == std::string_view::npos) break;
    start = p + 1;
  }
  return out;
}

double number(const std::string& text, std::string_view option) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v))
    throw UsageError(std::string(option) + " needs numbers, got '" + text + "'");
  return v;
}

struct Options {
  std::vector<std::string> csv;
  std::string out, x;
  std::vector<std::string> y, group, names;
  std::vector<std::pair<std::string, std::vector<std::string>>> where;
  chart::Style style = chart::Style::LinePoints;
  std::string mark, mark_label;
  bool pareto = false;
  chart::ChartSpec spec;
  bool xlabel_set = false, ylabel_set = false;
};

// --style line|points|linepoints.
chart::Style parse_style(const std::string& s) {
  if (s == "line") return chart::Style::Line;
  if (s == "points") return chart::Style::Points;
  if (s == "linepoints") return chart::Style::LinePoints;
  throw UsageError("--style must be line, points or linepoints");
}

// --legend tr|tl|br|bl|none, into the chart's spec.
void parse_legend(const std::string& s, chart::ChartSpec& spec) {
  if (s == "none")
    spec.legend = false;
  else if (s == "tr")
    spec.legend_corner = chart::LegendCorner::TopRight;
  else if (s == "tl")
    spec.legend_corner = chart::LegendCorner::TopLeft;
  else if (s == "br")
    spec.legend_corner = chart::LegendCorner::BottomRight;
  else if (s == "bl")
    spec.legend_corner = chart::LegendCorner::BottomLeft;
  else
    throw UsageError("--legend must be tr, tl, br, bl or none");
}

// --xrange or --yrange LO,HI (either end may be empty), into the chart's spec.
void parse_range(std::string_view option, const std::string& text, chart::ChartSpec& spec) {
  const std::vector<std::string> ends = split(text, ',');
  if (ends.size() != 2) throw UsageError(std::string(option) + " needs LO,HI");
  std::optional<double> lo, hi;
  if (!ends[0].empty()) lo = number(ends[0], option);
  if (!ends[1].empty()) hi = number(ends[1], option);
  (option == "--xrange" ? spec.x_min : spec.y_min) = lo;
  (option == "--xrange" ? spec.x_max : spec.y_max) = hi;
}

// --size WxH, into the chart's spec.
void parse_size(const std::string& s, chart::ChartSpec& spec) {
  int w = 0, h = 0;
  char extra = 0;
  if (std::sscanf(s.c_str(), "%dx%d%c", &w, &h, &extra) != 2)
    throw UsageError("--size must be WxH, e.g. 900x600");
  spec.width = w;
  spec.height = h;
}

// The checks between options, and the axis titles that default to the columns.
void check_args(Options& o) {
  if (o.csv.empty() || o.out.empty() || o.x.empty() || o.y.empty())
    throw UsageError("--csv, --out, --x and --y are required");
  if (!o.names.empty() && o.names.size() != o.y.size())
    throw UsageError("--names needs one name per --y column");
  if (o.pareto && o.y.size() != 1) throw UsageError("--pareto needs exactly one --y column");
  if (o.pareto && !o.mark.empty()) throw UsageError("use either --pareto or --mark");
  if (o.csv.size() > 1 && (o.pareto || !o.mark.empty()))
    throw UsageError("--pareto and --mark take one --csv");
  if (!o.xlabel_set) o.spec.x_title = o.x;
  if (!o.ylabel_set) o.spec.y_title = o.y.size() == 1 ? o.y[0] : "";
}

// The chart's command line (--help prints the usage and exits).
Options parse_args(int argc, char** argv) {
  Options o;
  auto value = [&](int& i) -> std::string {
    if (i + 1 >= argc) throw UsageError(std::string(argv[i]) + " needs a value");
    return argv[++i];
  };
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    if (a == "--csv") {
      o.csv.push_back(value(i));
    } else if (a == "--out") {
      o.out = value(i);
    } else if (a == "--x") {
      o.x = value(i);
    } else if (a == "--y") {
      o.y = split(value(i), ',');
    } else if (a == "--group") {
      o.group = split(value(i), ',');
    } else if (a == "--names") {
      o.names = split(value(i), ',');
    } else if (a == "--where") {
      const std::string w = value(i);
      const std::size_t eq = w.find('=');
      if (eq == std::string::npos || eq == 0) throw UsageError("--where needs COL=VALUE");
      o.where.emplace_back(w.substr(0, eq), split(w.substr(eq + 1), '|'));
    } else if (a == "--style") {
      o.style = parse_style(value(i));
    } else if (a == "--mark") {
      o.mark = value(i);
    } else if (a == "--mark-label") {
      o.mark_label = value(i);
    } else if (a == "--pareto") {
      o.pareto = true;
    } else if (a == "--title") {
      o.spec.title = value(i);
    } else if (a == "--xlabel") {
      o.spec.x_title = value(i);
      o.xlabel_set = true;
    } else if (a == "--ylabel") {
      o.spec.y_title = value(i);
      o.ylabel_set = true;
    } else if (a == "--xrange" || a == "--yrange") {
      parse_range(a, value(i), o.spec);
    } else if (a == "--logx") {
      o.spec.log_x = true;
    } else if (a == "--logy") {
      o.spec.log_y = true;
    } else if (a == "--size") {
      parse_size(value(i), o.spec);
    } else if (a == "--legend") {
      parse_legend(value(i), o.spec);
    } else if (a == "-h" || a == "--help") {
      std::cout << kUsage;
      std::exit(0);
    } else {
      throw UsageError("unknown argument '" + std::string(a) + "'");
    }
  }
  check_args(o);
  return o;
}

void sort_by_x(chart::Series& s) {
  std::vector<std::size_t> idx(s.x.size());
  std::iota(idx.begin(), idx.end(), 0);
  std::stable_sort(idx.begin(), idx.end(),
                   [&](std::size_t a, std::size_t b) { return s.x[a] < s.x[b]; });
  std::vector<double> x, y;
  for (std::size_t i : idx) {
    x.push_back(s.x[i]);
    y.push_back(s.y[i]);
  }
  s.x = std::move(x);
  s.y = std::move(y);
}

// The rows of `table` that every --where filter keeps.
std::vector<std::size_t> kept_rows(const Options& o, const chart::Table& table,
                                   const std::string& csv) {
  std::vector<std::size_t> where_cols;
  for (const auto& w : o.where) where_cols.push_back(table.column(w.first));
  std::vector<std::size_t> rows;
  for (std::size_t r = 0; r < table.rows.size(); ++r) {
    bool keep = true;
    for (std::size_t k = 0; k < o.where.size(); ++k) {
      const std::vector<std::string>& allowed = o.where[k].second;
      keep = keep && std::find(allowed.begin(), allowed.end(), table.rows[r][where_cols[k]]) !=
                         allowed.end();
    }
    if (keep) rows.push_back(r);
  }
  if (rows.empty()) throw UsageError("no row of '" + csv + "' passes the --where filters");
  return rows;
}

// The series of --y column `yi`: one per --group key, in order of first appearance.
void add_column_series(const Options& o, const chart::Table& table,
                       const std::vector<std::size_t>& rows,
                       const std::vector<std::size_t>& group_cols, const std::vector<double>& xs,
                       std::size_t yi, const std::string& prefix, chart::ChartSpec& spec) {
  const std::vector<double> ys = table.numbers(o.y[yi]);
  const std::string yname = o.names.empty() ? o.y[yi] : o.names[yi];
  std::vector<std::string> keys;
  std::map<std::string, chart::Series> by_key;
  for (std::size_t r : rows) {
    std::string key;
    for (std::size_t c : group_cols) key += (key.empty() ? "" : " / ") + table.rows[r][c];
    auto [it, fresh] = by_key.try_emplace(key);
    if (fresh) {
      keys.push_back(key);
      it->second.style = o.style;
      if (key.empty())
        it->second.name = yname;
      else
        it->second.name = o.y.size() > 1 ? yname + ": " + key : key;
      if (!prefix.empty())
        it->second.name = prefix + (key.empty() && o.y.size() == 1 ? "" : ": " + it->second.name);
    }
    it->second.x.push_back(xs[r]);
    it->second.y.push_back(ys[r]);
  }
  for (const std::string& k : keys) {
    chart::Series s = std::move(by_key[k]);
    if (o.style != chart::Style::Points) sort_by_x(s);
    spec.series.push_back(std::move(s));
  }
}

// The highlighted series: rows marked by the --mark column, or the computed Pareto front.
chart::Series highlighted_series(const Options& o, const chart::Table& table,
                                 const std::vector<std::size_t>& rows,
                                 const std::vector<double>& xs, const chart::ChartSpec& spec) {
  chart::Series m;
  m.highlight = true;
  m.style = chart::Style::LinePoints;
  m.line_width = 1.5f;
  if (o.pareto) {
    m.name = o.mark_label.empty() ? "Pareto front" : o.mark_label;
    const std::vector<double> ys = table.numbers(o.y[0]);
    std::vector<double> fx, fy;
    for (std::size_t r : rows) {
      const bool ok = (!spec.log_x || xs[r] > 0.0) && (!spec.log_y || ys[r] > 0.0);
      fx.push_back(ok ? xs[r] : std::nan(""));
      fy.push_back(ok ? ys[r] : std::nan(""));
    }
    for (std::size_t i : chart::pareto_front(fx, fy)) {
      m.x.push_back(fx[i]);
      m.y.push_back(fy[i]);
    }
  } else {
    m.name = o.mark_label.empty() ? o.mark : o.mark_label;
    if (o.y.size() > 1) m.style = chart::Style::Points;  // marks on several curves
    const std::vector<double> flags = table.numbers(o.mark);
    for (std::size_t yi = 0; yi < o.y.size(); ++yi) {
      const std::vector<double> ys = table.numbers(o.y[yi]);
      for (std::size_t r : rows)
        if (std::isfinite(flags[r]) && flags[r] != 0.0) {
          m.x.push_back(xs[r]);
          m.y.push_back(ys[r]);
        }
    }
    sort_by_x(m);
  }
  if (m.x.size() == 1) m.style = chart::Style::Points;  // a line needs two points
  return m;
}

// The series of one CSV file (with its name before each series when `prefix` is not empty).
chart::ChartSpec build(const Options& o, const chart::Table& table, const std::string& csv,
                       const std::string& prefix) {
  const std::vector<std::size_t> rows = kept_rows(o, table, csv);
  std::vector<std::size_t> group_cols;
  for (const std::string& g : o.group) group_cols.push_back(table.column(g));
  const std::vector<double> xs = table.numbers(o.x);
  chart::ChartSpec spec = o.spec;
  for (std::size_t yi = 0; yi < o.y.size(); ++yi)
    add_column_series(o, table, rows, group_cols, xs, yi, prefix, spec);
  if (!o.mark.empty() || o.pareto) {
    chart::Series m = highlighted_series(o, table, rows, xs, spec);
    if (!m.x.empty()) spec.series.push_back(std::move(m));
  }
  return spec;
}

}  // namespace

// palpchart --sheet OUT.png [--columns N] IN.png...
int contact_sheet(int argc, char** argv) {
  std::string out;
  int columns = 3;
  std::vector<std::string> inputs;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::cout << kUsage;
      return 0;
    }
    if (a == "--sheet" || a == "--columns") {
      if (i + 1 >= argc) throw UsageError(a + " needs a value");
      const std::string v = argv[++i];
      if (a == "--sheet") {
        out = v;
      } else {
        try {
          columns = std::stoi(v);
        } catch (const std::exception&) {
          throw UsageError("--columns must be a whole number, got '" + v + "'");
        }
      }
    } else {
      inputs.push_back(a);
    }
  }
  chart::write_contact_sheet(inputs, columns, out);
  return 0;
}

int main(int argc, char** argv) {
  try {
    for (int i = 1; i < argc; ++i)
      if (std::string_view(argv[i]) == "--sheet") return contact_sheet(argc, argv);
    const Options o = parse_args(argc, argv);
    if (!chart::display_available()) {
      // once: under xvfb-run, when installed (the variable stops a loop if it gave no display)
      if (!std::getenv("PALPCHART_UNDER_XVFB") &&
          std::system("command -v xvfb-run >/dev/null") == 0) {
        ::setenv("PALPCHART_UNDER_XVFB", "1", 1);
        std::vector<char*> args{const_cast<char*>("xvfb-run"), const_cast<char*>("-a")};
        for (int i = 0; i < argc; ++i) args.push_back(argv[i]);
        args.push_back(nullptr);
        ::execvp("xvfb-run", args.data());
      }
      std::cerr << chart::no_display_message("palpchart") << "\n";
      return 1;
    }
    chart::ChartSpec spec;
    for (const std::string& csv : o.csv) {
      const chart::Table table = chart::read_csv(csv);
      const std::string prefix =
          o.csv.size() > 1 ? std::filesystem::path(csv).stem().string() : std::string();
      chart::ChartSpec one = build(o, table, csv, prefix);
      if (spec.series.empty()) {
        spec = std::move(one);
      } else {
        for (chart::Series& s : one.series) spec.series.push_back(std::move(s));
      }
    }
    chart::render_png(spec, o.out);
    return 0;
  } catch (const UsageError& e) {
    std::cerr << "palpchart: " << e.what() << "\n" << kUsage;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "palpchart: " << e.what() << "\n";
    return 1;
  }
}
