// The report's SVG writer (svg.hpp).
#include "training/svg.hpp"

#include <cmath>
#include <cstdio>
#include <utility>

namespace palp::training {
namespace {

// A coordinate or width, to 0.01 user units; non-finite values as 0 (never "nan" in a document).
std::string num(double v) {
  if (!std::isfinite(v)) v = 0.0;
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", v);
  return text;
}

}  // namespace

std::string xml_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        if (static_cast<unsigned char>(c) >= 0x20 || c == '\t' || c == '\n') out += c;
    }
  }
  return out;
}

std::string base64(std::string_view bytes) {
  static constexpr char kDigits[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = static_cast<unsigned char>(bytes[i]) << 16 |
                       static_cast<unsigned char>(bytes[i + 1]) << 8 |
                       static_cast<unsigned char>(bytes[i + 2]);
    out += kDigits[v >> 18 & 63], out += kDigits[v >> 12 & 63];
    out += kDigits[v >> 6 & 63], out += kDigits[v & 63];
  }
  if (const std::size_t rest = bytes.size() - i; rest > 0) {
    unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    if (rest == 2) v |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    out += kDigits[v >> 18 & 63], out += kDigits[v >> 12 & 63];
    out += rest == 2 ? kDigits[v >> 6 & 63] : '=';
    out += '=';
  }
  return out;
}

Svg::Svg(double width, double height) : width_(width), height_(height) {}

void Svg::shape(const std::string& open, const SvgStyle& style) {
  body_ += open + " stroke=\"" + xml_escape(style.stroke) + "\" fill=\"" + xml_escape(style.fill) +
           "\" stroke-width=\"" + num(style.stroke_width) + "\"";
  if (!style.dash.empty()) body_ += " stroke-dasharray=\"" + xml_escape(style.dash) + "\"";
  if (style.opacity < 1.0) body_ += " opacity=\"" + num(style.opacity) + "\"";
  body_ += "/>\n";
}

void Svg::line(SvgPoint a, SvgPoint b, const SvgStyle& style) {
  shape("<line x1=\"" + num(a.x) + "\" y1=\"" + num(a.y) + "\" x2=\"" + num(b.x) + "\" y2=\"" +
            num(b.y) + "\"",
        style);
}

void Svg::polyline(const std::vector<SvgPoint>& points, const SvgStyle& style) {
  if (points.size() < 2) return;
  std::string list;
  for (const SvgPoint& p : points) list += num(p.x) + "," + num(p.y) + " ";
  list.pop_back();
  shape("<polyline stroke-linejoin=\"round\" points=\"" + list + "\"", style);
}

void Svg::circle(SvgPoint centre, double radius, const SvgStyle& style) {
  shape(
      "<circle cx=\"" + num(centre.x) + "\" cy=\"" + num(centre.y) + "\" r=\"" + num(radius) + "\"",
      style);
}

void Svg::rect(SvgPoint corner, double width, double height, const SvgStyle& style) {
  shape("<rect x=\"" + num(corner.x) + "\" y=\"" + num(corner.y) + "\" width=\"" + num(width) +
            "\" height=\"" + num(height) + "\"",
        style);
}

void Svg::text(SvgPoint at, std::string_view content, double size, std::string_view anchor,
               std::string_view colour) {
  body_ += "<text x=\"" + num(at.x) + "\" y=\"" + num(at.y) + "\" font-size=\"" + num(size) +
           "\" font-family=\"sans-serif\" text-anchor=\"" + xml_escape(anchor) + "\" fill=\"" +
           xml_escape(colour) + "\">" + xml_escape(content) + "</text>\n";
}

void Svg::begin_clip(SvgPoint corner, double width, double height) {
  const std::string id = "clip" + std::to_string(++clips_);
  body_ += "<clipPath id=\"" + id + "\"><rect x=\"" + num(corner.x) + "\" y=\"" + num(corner.y) +
           "\" width=\"" + num(width) + "\" height=\"" + num(height) +
           "\"/></clipPath>\n<g clip-path=\"url(#" + id + ")\">\n";
}

void Svg::end_clip() {
  body_ += "</g>\n";
}

std::string Svg::str() const {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" +
         num(width_) + "\" height=\"" + num(height_) + "\" viewBox=\"0 0 " + num(width_) + " " +
         num(height_) + "\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n" + body_ +
         "</svg>\n";
}

std::string Svg::data_uri() const {
  return svg_data_uri(str());
}

std::string svg_data_uri(std::string_view document) {
  return "data:image/svg+xml;base64," + base64(document);
}

std::vector<double> nice_ticks(double lo, double hi, int count) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || count < 1) return {};
  if (hi < lo) std::swap(lo, hi);
  if (hi - lo < 1e-12) return {lo};
  const double rough = (hi - lo) / count;
  const double power = std::pow(10.0, std::floor(std::log10(rough)));
  double step = power;
  for (const double m : {1.0, 2.0, 5.0, 10.0})
    if (m * power >= rough) {
      step = m * power;
      break;
    }
  std::vector<double> ticks;
  const double first = std::ceil(lo / step - 1e-9);
  for (int k = 0; k < 1000; ++k) {
    const double v = (first + k) * step;
    if (v > hi + step * 1e-9) break;
    ticks.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
  }
  return ticks;
}

std::string fixed(double v, int decimals) {
  char text[48];
  std::snprintf(text, sizeof text, "%.*f", decimals, std::isfinite(v) ? v : 0.0);
  return text;
}

}  // namespace palp::training
