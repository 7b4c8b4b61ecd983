// The ribs (landmark_detection.hpp): rod-shaped bone pieces lateral of the column, under the body
// wall, each with its head end (the end nearest the column), its side and its centre line; the
// vertebra its head lies at numbers it, ribs whose head is outside the scan are numbered by their
// order among their numbered neighbours; and the intercostal spaces at the mid-axillary line.
//
// ribs.cpp finds the traces, rib_landmarks.cpp numbers them and finds the spaces.
#pragma once

#include <string>
#include <vector>

#include "anatomy/landmark_context.hpp"
#include "anatomy/spine_levels.hpp"

namespace palp::anatomy {

// The bone within this distance (mm) of the column's centre line, left and right, is the
// vertebra's own or the rib's head and neck against it: thoracic transverse processes reach
// 30-40 mm from the midline, the rib heads 20-30 mm. Ribs are looked for beyond it.
inline constexpr double kColumnHalfWidthMm = 40.0;
// A rib's head end is within this distance (mm) beyond that band: the neck runs on from the
// transverse process's tip (the costotransverse joint) to the rib's angle.
inline constexpr double kHeadReachMm = 15.0;
// A rib is 6-20 mm across (its cross-section's equivalent diameter: bone volume over centre
// line length; prep's bone_ribs.hpp uses the same band), at least this long (mm: the 12th rib,
// the shortest, is 50-150 mm from its angle on) and its centre line mostly within this depth
// (mm) of the skin (the ribs lie under the chest and abdominal wall).
inline constexpr double kRibMinWidthMm = 5.0, kRibMaxWidthMm = 20.0;
inline constexpr double kRibMinLengthMm = 40.0;
inline constexpr double kRibMaxDepthMm = 60.0;
// Centre line samples every this many mm of geodesic length along the rib.
inline constexpr double kRibStepMm = 5.0;

struct RibTrace {
  int side = 0;              // 0 right, 1 left
  Vec3d head{};              // the end nearest the column (index units)
  std::vector<Vec3d> line;   // centre line from the head end outward (index units)
  bool head_in_scan = true;  // false: the piece reaches the scan's edge far from the column
  int vertebra = -1;         // the spine segment the head lies at, -1 when none
  double length_mm = 0.0, width_mm = 0.0;
  double confidence = 0.0;  // of being a rib (shape)
  // The labelled rib it is (skeleton_labels.hpp): number 0 when unlabelled.
  int label_number = 0;
  int label_side = 0;
  std::string label_name;
};

// The ribs of the scan, each with a head in the scan assigned to a spine segment (before the
// segments are named).
std::vector<RibTrace> find_ribs(const ScanContext& scan, const Spine& spine);

// The mid-axillary line (MAL) at a level: the skin point straight lateral (along patient x) of
// the body's centre (the centroid of the body mask's axial slice) in the coronal plane through
// that centre, the body's lateral-most point there for an elliptic section (the trunk phantom's
// definition, io/phantom_trunk.hpp). A point's angle about that centre in the axial plane
// (degrees, mm-scaled): 0 on the MAL's coronal plane, positive behind it, negative in front.
double angle_behind_mal(const ScanContext& scan, const Vec3d& index_point);

// Ribs numbered from the named vertebrae (the heads outside the scan by their order at a common
// angle), and the spaces between consecutive ribs at the mid-axillary line.
void rib_landmarks(const ScanContext& scan, const Spine& spine, const std::vector<RibTrace>& ribs,
                   Landmarks& out);

}  // namespace palp::anatomy
