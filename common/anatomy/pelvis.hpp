// The pelvis's landmarks (landmark_detection.hpp): each hip bone as the largest bone piece lateral
// of the column beside the sacrum, its iliac crest's top, its anterior superior iliac spine, the
// pubic symphysis, and the femoral pulse points.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "anatomy/landmark_context.hpp"
#include "anatomy/spine_levels.hpp"

namespace palp::anatomy {

struct Pelvis {
  // [0] right, [1] left; patient index units
  std::array<std::optional<Vec3d>, 2> crest_top;
  std::array<std::optional<Vec3d>, 2> asis;  // anterior superior iliac spine
  std::array<double, 2> confidence{0.0, 0.0};
  std::array<std::string, 2> reason;
  std::optional<Vec3d> symphysis;  // the pubic symphysis's upper border
};

Pelvis find_pelvis(const ScanContext& scan, const Spine& spine);

// Over the common femoral artery below the inguinal ligament when scan.artery shows it, else
// over the mid-inguinal point (midway between the ASIS and the symphysis).
std::vector<FemoralPulsePoint> femoral_pulse_points(const ScanContext& scan, const Pelvis& pelvis);

}  // namespace palp::anatomy
