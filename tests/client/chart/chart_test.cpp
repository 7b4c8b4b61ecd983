// The chart renderer (client/chart/chart.hpp) and palpchart: CSV parsing and Pareto fronts without
// a display; with one (CTest runs this under xvfb-run -a where DISPLAY is unset) a tiny chart is
// rendered and read back with vtkPNGReader: the PNG exists, has the requested size and is not
// blank. Without a display the rendering tests skip.
#include "chart/chart.hpp"

#include <gtest/gtest.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPNGReader.h>
#include <vtkPointData.h>
#include <vtkUnsignedCharArray.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include <unistd.h>

#include "base/errors.hpp"

namespace palp::chart {
namespace {

namespace fs = std::filesystem;

// A fresh directory per test and process.
fs::path temp_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir = fs::temp_directory_path() /
                       ("palp_chart_test_" + std::to_string(::getpid()) + "_" + info->name());
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

struct Png {
  int width = 0, height = 0;
  std::size_t distinct_colours = 0;
  double non_white_fraction = 0.0;
};

Png read_png(const std::string& path) {
  vtkNew<vtkPNGReader> reader;
  reader->SetFileName(path.c_str());
  reader->Update();
  vtkImageData* image = reader->GetOutput();
  Png out;
  int dims[3] = {0, 0, 0};
  image->GetDimensions(dims);
  out.width = dims[0];
  out.height = dims[1];
  auto* pixels = vtkUnsignedCharArray::SafeDownCast(image->GetPointData()->GetScalars());
  if (!pixels) return out;
  const int nc = pixels->GetNumberOfComponents();
  std::set<std::uint32_t> colours;
  std::size_t non_white = 0;
  const vtkIdType n = pixels->GetNumberOfTuples();
  for (vtkIdType i = 0; i < n; ++i) {
    std::uint32_t c = 0;
    bool white = true;
    for (int k = 0; k < std::min(nc, 3); ++k) {
      const unsigned v = pixels->GetValue(i * nc + k);
      c = (c << 8) | v;
      white = white && v == 255;
    }
    colours.insert(c);
    non_white += !white;
  }
  out.distinct_colours = colours.size();
  out.non_white_fraction = n > 0 ? static_cast<double>(non_white) / static_cast<double>(n) : 0.0;
  return out;
}

ChartSpec tiny_spec() {
  ChartSpec spec;
  spec.title = "tiny";
  spec.x_title = "x";
  spec.y_title = "y";
  spec.width = 320;
  spec.height = 200;
  Series a;
  a.name = "square";
  Series b;
  b.name = "line";
  b.style = Style::Points;
  for (int i = 1; i <= 10; ++i) {
    a.x.push_back(i);
    a.y.push_back(i * i);
    b.x.push_back(i);
    b.y.push_back(3.0 * i + 5.0);
  }
  Series front;
  front.name = "front";
  front.highlight = true;
  front.x = {1.0, 5.0};
  front.y = {1.0, 20.0};
  spec.series = {a, b, front};
  return spec;
}

TEST(Chart, ParsesCsvWithQuotesAndBlankLines) {
  const Table t = parse_csv("a,b,\"c,d\"\n1,2,\"x \"\"y\"\"\"\n\n3,4.5,z\r\n");
  ASSERT_EQ(t.columns.size(), 3u);
  EXPECT_EQ(t.columns[2], "c,d");
  ASSERT_EQ(t.rows.size(), 2u);
  EXPECT_EQ(t.rows[0][2], "x \"y\"");
  EXPECT_EQ(t.column("b"), 1u);
  const std::vector<double> b = t.numbers("b");
  EXPECT_EQ(b[0], 2.0);
  EXPECT_EQ(b[1], 4.5);
  EXPECT_TRUE(std::isnan(t.numbers("c,d")[1]));
  EXPECT_THROW(t.column("nope"), UsageError);
  EXPECT_THROW(parse_csv("a,b\n1,2,3\n"), InputError);
  EXPECT_THROW(parse_csv("a,b\n\"1,2\n"), InputError);
  EXPECT_THROW(parse_csv(""), InputError);
  EXPECT_THROW(read_csv("/nonexistent/palp.csv"), InputError);
}

TEST(Chart, ParetoFrontMinimisesBoth) {
  //            0    1    2    3    4    5
  const std::vector<double> x{1.0, 2.0, 3.0, 2.0, 5.0, std::nan("")};
  const std::vector<double> y{9.0, 4.0, 5.0, 4.0, 1.0, 0.0};
  const std::vector<std::size_t> f = pareto_front(x, y);
  // 2 is dominated by 1; 3 duplicates 1; 5 is not finite.
  EXPECT_EQ(f, (std::vector<std::size_t>{0, 1, 4}));
  EXPECT_TRUE(pareto_front({}, {}).empty());
}

TEST(Chart, RefusesUnusableSpecs) {
  ChartSpec empty;
  EXPECT_THROW(render_png(empty, "x.png"), UsageError);
  ChartSpec bad = tiny_spec();
  bad.series[0].y.pop_back();
  EXPECT_THROW(render_png(bad, "x.png"), UsageError);
  ChartSpec tiny = tiny_spec();
  tiny.width = 4;
  EXPECT_THROW(render_png(tiny, "x.png"), UsageError);
  ChartSpec negative;
  negative.log_y = true;
  Series neg;
  neg.name = "neg";
  neg.x = {1.0, 2.0};
  neg.y = {-1.0, 0.0};
  negative.series.push_back(neg);
  EXPECT_THROW(render_png(negative, "x.png"), UsageError);
}

TEST(Chart, RendersANonBlankPngOfTheRequestedSize) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  const fs::path dir = temp_dir();
  const std::string path = (dir / "tiny.png").string();
  render_png(tiny_spec(), path);
  ASSERT_TRUE(fs::exists(path));
  const Png png = read_png(path);
  EXPECT_EQ(png.width, 320);
  EXPECT_EQ(png.height, 200);
  // Text, axes, three series in different colours and anti-aliasing: many colours.
  EXPECT_GE(png.distinct_colours, 8u);
  EXPECT_GT(png.non_white_fraction, 0.01);
  EXPECT_LT(png.non_white_fraction, 0.9);

  // Log axes render too.
  ChartSpec log = tiny_spec();
  log.log_x = log.log_y = true;
  log.width = 400;
  const std::string log_path = (dir / "log.png").string();
  render_png(log, log_path);
  const Png lp = read_png(log_path);
  EXPECT_EQ(lp.width, 400);
  EXPECT_GE(lp.distinct_colours, 8u);
  fs::remove_all(dir);
}

TEST(Chart, PalpchartDrawsCsvColumns) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  const fs::path dir = temp_dir();
  const fs::path csv = dir / "in.csv";
  {
    std::ofstream out(csv);
    out << "t,a,b,kind,front\n";
    for (int i = 1; i <= 8; ++i)
      out << i << "," << i * 0.5 << "," << 10.0 / i << "," << (i % 2 ? "odd" : "even") << ","
          << (i == 3) << "\n";
  }
  const fs::path png = dir / "out.png";
  const std::string cmd =
      std::string(PALPCHART_PATH) + " --csv " + csv.string() +
      " --x t --y a,b --group kind --mark front --logy --yrange 0.1, --size 300x220 --out " +
      png.string() + " --title 'a test'";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const Png p = read_png(png.string());
  EXPECT_EQ(p.width, 300);
  EXPECT_EQ(p.height, 220);
  EXPECT_GE(p.distinct_colours, 8u);
  // A usage error exits 2 and writes nothing.
  const std::string bad = std::string(PALPCHART_PATH) + " --csv " + csv.string() +
                          " --x t --y nope --out " + (dir / "bad.png").string() + " 2>/dev/null";
  const int rc = std::system(bad.c_str());
  EXPECT_TRUE(WIFEXITED(rc) && WEXITSTATUS(rc) == 2);
  EXPECT_FALSE(fs::exists(dir / "bad.png"));
  fs::remove_all(dir);
}

// Without a display palpchart runs itself under xvfb-run when it is installed; where it cannot
// (here: told it already did), it says what to install and writes nothing.
TEST(Chart, PalpchartWithoutDisplayRunsUnderXvfbOrSaysSo) {
  const fs::path dir = temp_dir();
  const fs::path csv = dir / "in.csv";
  {
    std::ofstream out(csv);
    out << "x,y\n1,2\n2,3\n";
  }
  const std::string args =
      std::string(PALPCHART_PATH) + " --csv " + csv.string() + " --x x --y y --out ";
  if (std::system("command -v xvfb-run >/dev/null") == 0) {
    const std::string cmd = "env -u DISPLAY " + args + (dir / "x.png").string() + " 2>/dev/null";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    EXPECT_TRUE(fs::exists(dir / "x.png"));
  }
  const fs::path log = dir / "err.txt";
  const std::string cmd = "env -u DISPLAY PALPCHART_UNDER_XVFB=1 " + args +
                          (dir / "o.png").string() + " 2>" + log.string();
  const int rc = std::system(cmd.c_str());
  EXPECT_TRUE(WIFEXITED(rc) && WEXITSTATUS(rc) == 1);
  std::ifstream in(log);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("xvfb-run"), std::string::npos) << text;
  EXPECT_FALSE(fs::exists(dir / "o.png"));
  fs::remove_all(dir);
}

// Several --csv files overlay on one chart, a legend entry per file (its name); --mark and
// --pareto take one file.
TEST(Chart, PalpchartOverlaysSeveralCsvFiles) {
  if (!display_available()) GTEST_SKIP() << "no X display (run under xvfb-run -a)";
  const fs::path dir = temp_dir();
  for (const char* name : {"before", "after"}) {
    std::ofstream out(dir / (std::string(name) + ".csv"));
    out << "x,y\n";
    for (int i = 1; i <= 6; ++i) out << i << "," << (name[0] == 'b' ? i : 2 * i) << "\n";
  }
  const std::string both = " --csv " + (dir / "before.csv").string() + " --csv " +
                           (dir / "after.csv").string() + " --x x --y y --size 300x200 --out ";
  const std::string cmd = std::string(PALPCHART_PATH) + both + (dir / "both.png").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const Png one_file_png = [&] {
    const std::string c1 = std::string(PALPCHART_PATH) + " --csv " + (dir / "before.csv").string() +
                           " --x x --y y --size 300x200 --out " + (dir / "one.png").string();
    EXPECT_EQ(std::system(c1.c_str()), 0);
    return read_png((dir / "one.png").string());
  }();
  const Png both_png = read_png((dir / "both.png").string());
  EXPECT_EQ(both_png.width, 300);
  EXPECT_GT(both_png.distinct_colours, one_file_png.distinct_colours);  // a second colour
  const std::string marked =
      std::string(PALPCHART_PATH) + both + (dir / "m.png").string() + " --mark y 2>/dev/null";
  const int rc = std::system(marked.c_str());
  EXPECT_TRUE(WIFEXITED(rc) && WEXITSTATUS(rc) == 2);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace palp::chart
