// A number as the consoles' JSON reports write it: six significant digits, and null where it is
// not finite (JSON has no NaN or infinity).
#pragma once

#include <cmath>
#include <cstdio>
#include <string>

namespace palp::cli {

inline std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  char text[64];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

}  // namespace palp::cli
