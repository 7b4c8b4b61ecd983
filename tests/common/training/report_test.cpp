// The session report: the page is well-formed enough for a browser, holds every metric, escapes
// what the user gave, draws the anatomy in the path chart; and, where Chromium is installed
// (Debian's chromium), the page renders headless with its table and every image decoded.
#include "training/report.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "support/training_session.hpp"
#include "training/svg.hpp"

namespace {

namespace fs = std::filesystem;
using namespace palp::training;
using palp::testing::ptcd_session;

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// The base64 payloads of the page's images, decoded.
std::vector<std::string> decoded_images(const std::string& html) {
  static const std::string kPrefix = "src=\"data:image/svg+xml;base64,";
  std::vector<std::string> out;
  for (auto at = html.find(kPrefix); at != std::string::npos; at = html.find(kPrefix, at + 1)) {
    const auto begin = at + kPrefix.size();
    const std::string b64 = html.substr(begin, html.find('"', begin) - begin);
    std::string bytes;
    unsigned buffer = 0;
    int bits = 0;
    for (const char c : b64) {
      const auto digit =
          std::string_view("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/")
              .find(c);
      if (digit == std::string_view::npos) break;
      buffer = buffer << 6 | static_cast<unsigned>(digit);
      if ((bits += 6) >= 8) bytes += static_cast<char>(buffer >> (bits -= 8) & 0xff);
    }
    out.push_back(bytes);
  }
  return out;
}

TEST(Report, SummaryTakesTheLastMarkAsTheAnswer) {
  palp::training::Session session = ptcd_session();
  const TrialSummary one = summarize(session.trials[0]);
  EXPECT_EQ(one.marks, 1u);
  EXPECT_EQ(one.where, "target");
  EXPECT_TRUE(one.in_target.value());
  EXPECT_NEAR(one.distance_mm.value(), 4.5, 1e-9);
  const TrialSummary two = summarize(session.trials[1]);
  EXPECT_EQ(two.where, "rib 9");
  EXPECT_NEAR(two.distance_mm.value(), 15.5, 1e-9);
  session.trials[0].score.marks.clear();
  EXPECT_FALSE(summarize(session.trials[0]).in_target);
}

TEST(Report, PageIsWellFormedAndHoldsTheMetrics) {
  const std::string html = report_html(ptcd_session());
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  for (const char* tag : {"html", "head", "body", "table", "tr", "td", "th", "h2", "p", "script"})
    EXPECT_EQ(count(html, std::string("<") + tag + ">") + count(html, std::string("<") + tag + " "),
              count(html, std::string("</") + tag + ">"))
        << tag;
  EXPECT_EQ(count(html, "<img "), 4u) << "two charts per trial";
  EXPECT_NE(html.find("palp task: ptcd right 9/10"), std::string::npos);
  // Trial 1's row: 1 mark, target, 4.5 mm, mark at 0.90 s, peak 4.50 N (the ramp at the mark's
  // end: 5 N/s x 1 s = 5.00), path 18.0 mm, 0.90 s in contact, 1.00 s long.
  EXPECT_NE(html.find("<tr data-trial=\"1\"><td>1</td><td>1</td><td class=\"text\">target</td>"
                      "<td class=\"hit\">yes</td><td>4.5</td><td>4.5</td><td>0.90</td>"
                      "<td>5.00</td><td>2.75</td><td>18.0</td><td>0.90</td><td>1.00</td></tr>"),
            std::string::npos)
      << html.substr(html.find("<table id=\"metrics\">"), 1200);
  EXPECT_NE(html.find("<td class=\"text\">rib 9</td><td class=\"miss\">no</td><td>15.5</td>"),
            std::string::npos);
}

TEST(Report, EscapesWhatTheUserGave) {
  palp::training::Session session = ptcd_session("<script>alert('x')</script>");
  session.id = "a\"b&c";
  session.landmarks.notes.push_back("<img src=x onerror=alert(1)>");
  const std::string html = report_html(session);
  EXPECT_EQ(count(html, "<script"), 1u) << "only the page's own";
  EXPECT_NE(html.find("&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;"), std::string::npos);
  EXPECT_NE(html.find("a&quot;b&amp;c"), std::string::npos);
  EXPECT_EQ(html.find("<img src=x"), std::string::npos);
}

TEST(Report, ChartsDrawTheForceMarksAnatomyAndPath) {
  const palp::training::Session session = ptcd_session();
  const std::string force = force_chart_svg(session.trials[0]);
  EXPECT_NE(force.find("normal force (N)"), std::string::npos);
  EXPECT_EQ(count(force, "<polyline"), 1u);
  EXPECT_NE(force.find("stroke=\"#1a9850\""), std::string::npos) << "the mark in the target";
  const std::string path = path_chart_svg(session, session.trials[1]);
  EXPECT_NE(path.find(">rib 9</text>"), std::string::npos);
  EXPECT_NE(path.find(">rib 10</text>"), std::string::npos);
  EXPECT_NE(path.find("seen from the right"), std::string::npos);
  EXPECT_NE(path.find("towards the patient&#39;s anterior"), std::string::npos);
  EXPECT_NE(path.find("fill=\"#d73027\""), std::string::npos) << "the mark on the rib, in red";
  const std::vector<std::string> images = decoded_images(report_html(session));
  ASSERT_EQ(images.size(), 4u);
  EXPECT_EQ(images[1], path_chart_svg(session, session.trials[0]));
}

TEST(Report, WritesThePageIntoANewDirectory) {
  const fs::path dir = fs::path(::testing::TempDir()) / "palp_report_test" / "nested";
  fs::remove_all(dir.parent_path());
  const std::string path = write_report(dir.string(), ptcd_session());
  EXPECT_EQ(path, (dir / "report.html").string());
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), report_html(ptcd_session()));
  EXPECT_FALSE(fs::exists(path + ".partial"));
}

// Runs `command`, returns its standard output.
std::string output_of(const std::string& command) {
  std::string out;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return out;
  std::array<char, 4096> buffer{};
  while (const std::size_t n = std::fread(buffer.data(), 1, buffer.size(), pipe))
    out.append(buffer.data(), n);
  ::pclose(pipe);
  return out;
}

// Debian's chromium, headless: the DOM after the page's load, with the images' flag the page's
// script sets; and a screenshot. Under ~10 s; skipped where Chromium is not installed.
TEST(ReportInChromium, RendersTheTableAndEveryImage) {
  if (std::system("command -v chromium >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "chromium is not installed (deploy/install-deps.sh installs it)";
  const fs::path dir = fs::path(::testing::TempDir()) / "palp_report_chromium";
  fs::remove_all(dir);
  const std::string page = write_report(dir.string(), ptcd_session());
  const std::string chromium =
      "timeout 60 chromium --headless --no-sandbox --disable-gpu "
      "--no-first-run --user-data-dir=" +
      (dir / "profile").string();
  const std::string dom = output_of(chromium + " --dump-dom file://" + page + " 2>/dev/null");
  ASSERT_NE(dom.find("</html>"), std::string::npos) << "no DOM from chromium: " << dom;
  EXPECT_NE(dom.find("data-images-loaded=\"yes\""), std::string::npos)
      << dom.substr(0, dom.find("<h1>"));
  EXPECT_NE(dom.find("data-images=\"4\""), std::string::npos);
  EXPECT_NE(dom.find("<td class=\"text\">target</td><td class=\"hit\">yes</td><td>4.5</td>"),
            std::string::npos);
  EXPECT_NE(dom.find("<td class=\"text\">rib 9</td>"), std::string::npos);
  const fs::path shot = dir / "report.png";
  output_of(chromium + " --hide-scrollbars --window-size=1200,1600 --screenshot=" + shot.string() +
            " file://" + page + " >/dev/null 2>&1");
  ASSERT_TRUE(fs::exists(shot));
  EXPECT_GT(fs::file_size(shot), 10000u) << "a page with charts, not a blank one";
}

}  // namespace
