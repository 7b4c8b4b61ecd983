// Tools: the contact points a device carries, in the tool frame (mm; the device point is the
// origin, spec "Tools"). Parsed once at setup from "finger:N", "twofinger:N" or "probe:NXxNY".
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "base/vec.hpp"

namespace palp {

enum class ToolKind { Finger, TwoFinger, Probe };

struct Tool {
  ToolKind kind = ToolKind::Finger;
  std::string name;           // canonical spelling, e.g. "finger:37", "probe:9x3"
  std::vector<Vec3d> points;  // contact points in the tool frame, mm
  int per_pad = 0;            // finger / twofinger: points per pad (1, 7, 19 or 37)
  int nx = 0, ny = 0;         // probe: grid counts along x and y
};

// Finger pad geometry (spec): centre (0, 0, -8) plus rings r = 1..3 of 6r points at radius
// 2.5 r mm, azimuth 2 pi j / (6r); N = 1, 7, 19, 37 use 0..3 rings.
inline constexpr double kFingerPadZ = -8.0;
inline constexpr double kFingerRingPitch = 2.5;
inline constexpr double kTwoFingerPadX = 9.5;  // pads centred at x = -9.5 and +9.5
// Probe face: z = -50, x from -20 to 20, y from -6 to 6.
inline constexpr double kProbeFaceZ = -50.0;
inline constexpr double kProbeHalfX = 20.0;
inline constexpr double kProbeHalfY = 6.0;
inline constexpr int kProbeMaxCount = 100;  // per axis

// Parses a tool string. Accepted: "finger:N" and "twofinger:N" with N in {1, 7, 19, 37} (N is
// per pad; "finger" and "twofinger" alone mean N = 37), "probe:NXxNY" with 1 <= NX, NY <= 100
// ("probe" alone means 9x3). Throws UsageError naming the string otherwise.
Tool parse_tool(std::string_view spec);

// The points of one finger pad of n points (1, 7, 19, 37) centred at (cx, 0, -8).
std::vector<Vec3d> finger_pad_points(int n, double cx);

const char* to_string(ToolKind kind);

}  // namespace palp
