// What every step of find_landmarks works on (landmark_detection.cpp builds it once).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "anatomy/landmarks.hpp"
#include "anatomy/patient_volume.hpp"

namespace palp::anatomy {

struct ScanContext {
  PatientMask bone;  // patient axis order: x left, y posterior, z superior
  PatientMask body;
  std::vector<SliceBody> bodies;  // per slice z
  SkinMap skin;
  std::optional<PatientMask> artery;
  std::string artery_source;
  std::optional<PatientMask> skeleton;      // labelled vertebrae and ribs: values, not 0/1
  std::vector<std::string> skeleton_names;  // value v: skeleton_names[v - 1]
  double midline_x = 0.0;                   // the column's median x (index), else the body's
};

// Index 0 is the patient's right (smaller x in LPS), 1 the left.
inline Side side_of(int s) {
  return s == 0 ? Side::right : Side::left;
}

// The skin point from `world` along the LPS direction `dir` (or, when `world` lies outside the
// body that way never enters it, against it), within 300 mm, and the skin's outward normal.
struct SkinPoint {
  Vec3d point{};
  Vec3d normal{};
};
std::optional<SkinPoint> skin_along(const ScanContext& scan, const Vec3d& world, const Vec3d& dir);

}  // namespace palp::anatomy
