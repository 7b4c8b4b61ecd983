// The ribs (landmark_detection.hpp): rod-shaped bone pieces lateral of the column whose medial
// end reaches it, each with its head (the medial end), its side and its centre line; the
// vertebra its head lies at numbers it; and the intercostal spaces at the mid-axillary line.
#pragma once

#include <vector>

#include "anatomy/landmark_context.hpp"
#include "anatomy/spine_levels.hpp"

namespace palp::anatomy {

struct RibTrace {
  int side = 0;             // 0 right, 1 left
  Vec3d head{};             // the medial end (index units)
  std::vector<Vec3d> line;  // centre line from the head outward (index units)
  int vertebra = -1;        // the spine segment the head lies at, -1 when none
  double confidence = 0.0;  // of being a rib (shape)
};

// The ribs of the scan, each assigned to a spine segment (before the segments are named).
std::vector<RibTrace> find_ribs(const ScanContext& scan, const Spine& spine);

// Ribs numbered from the named vertebrae, and the spaces between consecutive ribs at the
// mid-axillary line (the skin point straight lateral of the body's centre in the axial plane).
void rib_landmarks(const ScanContext& scan, const Spine& spine, const std::vector<RibTrace>& ribs,
                   Landmarks& out);

}  // namespace palp::anatomy
