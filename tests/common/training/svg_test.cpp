// The report's SVG writer: escaping, base64 against RFC 4648's vectors, nice ticks, and a
// document whose text cannot break out of its element.
#include "training/svg.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using namespace palp::training;

TEST(Svg, EscapesMarkupAndDropsControlCharacters) {
  EXPECT_EQ(xml_escape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&#39;");
  EXPECT_EQ(xml_escape(std::string("x\x01y\tz\n", 6)), "xy\tz\n");
}

TEST(Svg, Base64MatchesTheRfcVectors) {
  EXPECT_EQ(base64(""), "");
  EXPECT_EQ(base64("f"), "Zg==");
  EXPECT_EQ(base64("fo"), "Zm8=");
  EXPECT_EQ(base64("foo"), "Zm9v");
  EXPECT_EQ(base64("foob"), "Zm9vYg==");
  EXPECT_EQ(base64("fooba"), "Zm9vYmE=");
  EXPECT_EQ(base64("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64(std::string("\xff\xfe\x00", 3)), "//4A");
  EXPECT_EQ(svg_data_uri("foo"), "data:image/svg+xml;base64,Zm9v");
}

TEST(Svg, NiceTicksCoverTheRangeInRoundSteps) {
  const std::vector<double> unit = nice_ticks(0.0, 1.0, 5);
  ASSERT_EQ(unit.size(), 6u);
  for (std::size_t i = 0; i < unit.size(); ++i) EXPECT_NEAR(unit[i], 0.2 * i, 1e-12);
  const std::vector<double> t = nice_ticks(-37.0, 112.0);
  ASSERT_FALSE(t.empty());
  EXPECT_EQ(t.front(), 0.0) << "steps of 50 within the range";
  EXPECT_EQ(t.back(), 100.0);
  EXPECT_EQ(nice_ticks(3.0, 3.0), std::vector<double>{3.0});
  EXPECT_TRUE(nice_ticks(NAN, 1.0).empty());
}

TEST(Svg, DocumentHoldsShapesAndEscapedText) {
  Svg svg(100.0, 50.0);
  svg.line({0, 0}, {10, 10}, SvgStyle{"red\"/><script>", "none", 1.0, "2 2", 0.5});
  svg.polyline({{0, 0}, {1, 1}, {2, NAN}}, SvgStyle{});
  svg.circle({5, 5}, 2, SvgStyle{});
  svg.text({1, 1}, "</text><script>alert(1)</script>");
  const std::string doc = svg.str();
  EXPECT_EQ(doc.rfind("<?xml", 0), 0u);
  EXPECT_NE(doc.find("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"100.00\""),
            std::string::npos);
  EXPECT_EQ(doc.find("<script"), std::string::npos) << doc;
  EXPECT_EQ(doc.find("nan"), std::string::npos) << "a non-finite coordinate is written as 0";
  EXPECT_NE(doc.find("stroke-dasharray=\"2 2\""), std::string::npos);
  EXPECT_NE(doc.find("opacity=\"0.50\""), std::string::npos);
  EXPECT_NE(doc.find("</svg>"), std::string::npos);
}

}  // namespace
