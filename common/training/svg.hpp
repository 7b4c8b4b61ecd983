// A small SVG writer for the training report's charts (palpd runs headless, without a display
// or a plotting library): lines, polylines, circles, rectangles and text in user units, every
// text and attribute value escaped; and the base64 that puts an SVG inline in HTML as a data URI.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace palp::training {

// `text` with &, <, >, " and ' as XML/HTML character references (and control characters other
// than tab and newline dropped): safe inside an element or a quoted attribute.
std::string xml_escape(std::string_view text);

// RFC 4648 base64 with padding.
std::string base64(std::string_view bytes);
// An SVG document as an <img> source: data:image/svg+xml;base64,...
std::string svg_data_uri(std::string_view document);

struct SvgPoint {
  double x = 0.0;
  double y = 0.0;
};

// Style of a shape: SVG colour names or #rrggbb (written escaped), widths in user units.
struct SvgStyle {
  std::string stroke = "black";
  std::string fill = "none";
  double stroke_width = 1.0;
  std::string dash;      // stroke-dasharray, empty = solid
  double opacity = 1.0;  // of the stroke and the fill
};

class Svg {
 public:
  Svg(double width, double height);
  void line(SvgPoint a, SvgPoint b, const SvgStyle& style);
  void polyline(const std::vector<SvgPoint>& points, const SvgStyle& style);
  void circle(SvgPoint centre, double radius, const SvgStyle& style);
  void rect(SvgPoint corner, double width, double height, const SvgStyle& style);
  // anchor: "start", "middle" or "end".
  void text(SvgPoint at, std::string_view content, double size = 12.0,
            std::string_view anchor = "start", std::string_view colour = "black");
  // Shapes between begin_clip and end_clip are drawn only inside the rectangle (pairs nest).
  void begin_clip(SvgPoint corner, double width, double height);
  void end_clip();
  // The document, with its XML declaration.
  std::string str() const;
  // The document as an <img> source: data:image/svg+xml;base64,...
  std::string data_uri() const;

 private:
  void shape(const std::string& open, const SvgStyle& style);
  double width_, height_;
  std::string body_;
  int clips_ = 0;
};

// "Nice" axis ticks (1, 2 or 5 times a power of ten) covering [lo, hi], about `count` of them.
std::vector<double> nice_ticks(double lo, double hi, int count = 6);

// `v` with `decimals` decimals (a label or a table cell); not finite: 0.
std::string fixed(double v, int decimals);

}  // namespace palp::training
