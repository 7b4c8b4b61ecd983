#include "model/tool.hpp"

#include <charconv>
#include <cmath>
#include <numbers>

#include "base/errors.hpp"

namespace palp {
namespace {

[[noreturn]] void bad_tool(std::string_view spec, const std::string& why) {
  throw UsageError("tool '" + std::string(spec) + "': " + why +
                   " (expected finger:N or twofinger:N with N in {1, 7, 19, 37}, or "
                   "probe:NXxNY with 1..100 points per axis)");
}

// A plain decimal count: digits only, no sign, no spaces, nothing after it.
bool parse_count(std::string_view text, int& out) {
  if (text.empty() || text.size() > 6) return false;
  for (char ch : text)
    if (ch < '0' || ch > '9') return false;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc() && end == text.data() + text.size();
}

int rings_for(int n) {
  switch (n) {
    case 1:
      return 0;
    case 7:
      return 1;
    case 19:
      return 2;
    case 37:
      return 3;
    default:
      return -1;
  }
}

// Evenly from -half to +half; a single point sits at 0.
double grid_coord(int i, int count, double half) {
  if (count == 1) return 0.0;
  return -half + 2.0 * half * static_cast<double>(i) / static_cast<double>(count - 1);
}

}  // namespace

std::vector<Vec3d> finger_pad_points(int n, double cx) {
  const int rings = rings_for(n);
  std::vector<Vec3d> pts;
  if (rings < 0) return pts;
  pts.reserve(static_cast<std::size_t>(n));
  pts.push_back({cx, 0.0, kFingerPadZ});
  for (int r = 1; r <= rings; ++r) {
    const int count = 6 * r;
    const double radius = kFingerRingPitch * r;
    for (int j = 0; j < count; ++j) {
      const double phi = 2.0 * std::numbers::pi * j / count;
      pts.push_back({cx + radius * std::cos(phi), radius * std::sin(phi), kFingerPadZ});
    }
  }
  return pts;
}

Tool parse_tool(std::string_view spec) {
  const std::size_t colon = spec.find(':');
  const std::string_view kind = spec.substr(0, colon);
  const bool has_arg = colon != std::string_view::npos;
  const std::string_view arg = has_arg ? spec.substr(colon + 1) : std::string_view{};

  Tool tool;
  if (kind == "finger" || kind == "twofinger") {
    int n = 37;
    if (has_arg && !parse_count(arg, n)) bad_tool(spec, "N is not a count");
    if (rings_for(n) < 0) bad_tool(spec, "N must be 1, 7, 19 or 37");
    tool.per_pad = n;
    if (kind == "finger") {
      tool.kind = ToolKind::Finger;
      tool.points = finger_pad_points(n, 0.0);
    } else {
      tool.kind = ToolKind::TwoFinger;
      tool.points = finger_pad_points(n, -kTwoFingerPadX);
      const std::vector<Vec3d> right = finger_pad_points(n, kTwoFingerPadX);
      tool.points.insert(tool.points.end(), right.begin(), right.end());
    }
    tool.name = std::string(kind) + ":" + std::to_string(n);
    return tool;
  }
  if (kind == "probe") {
    int nx = 9, ny = 3;
    if (has_arg) {
      const std::size_t x = arg.find('x');
      if (x == std::string_view::npos) bad_tool(spec, "expected NXxNY");
      if (!parse_count(arg.substr(0, x), nx) || !parse_count(arg.substr(x + 1), ny))
        bad_tool(spec, "NX and NY must be counts");
    }
    if (nx < 1 || ny < 1 || nx > kProbeMaxCount || ny > kProbeMaxCount)
      bad_tool(spec, "NX and NY must be 1..100");
    tool.kind = ToolKind::Probe;
    tool.nx = nx;
    tool.ny = ny;
    tool.points.reserve(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny));
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        tool.points.push_back(
            {grid_coord(i, nx, kProbeHalfX), grid_coord(j, ny, kProbeHalfY), kProbeFaceZ});
    tool.name = "probe:" + std::to_string(nx) + "x" + std::to_string(ny);
    return tool;
  }
  bad_tool(spec, "unknown tool");
}

const char* to_string(ToolKind kind) {
  switch (kind) {
    case ToolKind::Finger:
      return "finger";
    case ToolKind::TwoFinger:
      return "twofinger";
    case ToolKind::Probe:
      return "probe";
  }
  return "?";
}

}  // namespace palp
