// The labelled vertebrae and ribs of prep --labels (a TotalSegmentator or 3D Slicer label map;
// landmark_detection.hpp's LandmarkInputs::skeleton_labels) as the landmarks' names. A label
// names its element outright: no counting from the sacrum is needed, so a labelled vertebra's
// name and a labelled rib's number and side are taken from the label map (confidence 0.95), and
// where the count from the anatomy (the sacrum, or T12 from the ribs) says otherwise the label
// map still wins, with a note and a lower confidence (0.8).
#pragma once

#include <string>
#include <vector>

#include "anatomy/landmark_context.hpp"
#include "anatomy/ribs.hpp"
#include "anatomy/spine_levels.hpp"

namespace palp::anatomy {

inline constexpr double kLabelledConfidence = 0.95;
inline constexpr double kLabelDisagreesConfidence = 0.8;

// Each spine segment takes the name of the labelled vertebra (or the sacrum: "S") most of the
// labelled voxels of its body belong to (its slices between its discs, within 25 mm of its
// centre across and from 30 mm in front of it back to the column's posterior wall), and its body
// centre becomes that label's centroid there (not the sacrum's: its label is the whole bone). A
// name the count gave otherwise is noted in spine.notes and the segment's reason.
void label_vertebrae(const ScanContext& scan, Spine& spine);

// Each rib trace takes the number and side of the labelled rib most of the labelled voxels
// around its centre line (within 2 voxels) belong to (RibTrace::label_*).
void label_ribs(const ScanContext& scan, std::vector<RibTrace>& ribs);

// "rib_left_9" -> side 1, number 9 ("rib_right_12": side 0); false for anything else.
bool parse_rib_label(const std::string& name, int& side, int& number);
// "vertebrae_L3" -> "L3", "sacrum" and "vertebrae_S1" -> "S"; empty for anything else.
std::string vertebra_of_label(const std::string& name);

}  // namespace palp::anatomy
