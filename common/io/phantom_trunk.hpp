// The trunk phantom's truth (phantom.hpp describes the phantom): every landmark a trainee palpates
// for, computed from the same geometry the phantom is drawn from, in the patient's LPS world frame
// (mm; x = patient left, y = posterior, z = superior) of the grid make_phantom("trunk", options)
// draws. The storage order (the `orient` option) changes the voxels, never these points.
//
// palp::io does not depend on palp::anatomy: this is plain data; anatomy/trunk_truth.hpp turns
// it into anatomy::Landmarks (trunk_landmark_truth).
//
// Definitions:
// - Mid-axillary line (MAL): at a level z, the skin point straight lateral of the body's centre
//   in the coronal plane through that centre (the body's cross-section is an ellipse centred at
//   (0, -25) mm in x, y at every z: the MAL point is (+-a(z), -25, z), a(z) the body's
//   half-width there, the body's lateral-most point at that level).
// - A rib's centre line crosses the MAL's coronal plane (y = -25) at its `mid_axillary` point.
// - Intercostal space N (below rib N): the skin point at the MAL at the level midway between
//   ribs N's and N+1's mid_axillary points, with the skin's outward unit normal there. Absent
//   where rib N+1 does not reach the MAL (rib 12 ends behind it: no 11th space there).
// - Spinous tip: the posterior end of the process's middle centre line plus its radius (the bone's
//   surface there, where its distal end ends).
// - Lumbar interspace "Lx/Ly": midway between the two spinous tips (for L5/S1 the first median
//   sacral crest's tubercle stands in for S1's), projected straight posterior (+y) to the skin,
//   with the skin's outward unit normal there.
// - Iliac crest top: the crest's most superior point (on the bone's surface).
// - Tuffier's line: the mean z of the two crest tops and the vertebral level it crosses ("L4"
//   inside a body, "L4/L5" inside a disc).
// - Femoral pulse point: on the skin straight anterior (-y) of the common femoral artery's centre
//   line where it passes under the inguinal ligament, at the mid-inguinal point's level (midway
//   between the anterior superior iliac spine and the pubic symphysis).
// Everything is listed when it lies inside the drawn volume (a thin slab lists less; rib points
// outside it are dropped).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "base/vec.hpp"
#include "io/phantom.hpp"

namespace palp {

enum class TrunkSide { right, left };  // the patient's

struct TrunkVertebra {
  std::string name;  // "T8".."T12", "L1".."L5", "S" (the sacrum)
  Vec3d body_centre;
  std::optional<Vec3d> spinous_tip;  // absent on the sacrum
  double z_lo = 0.0, z_hi = 0.0;     // the body's inferior and superior endplates (world z)
  std::uint8_t label = 0;            // in PhantomTruth::bone_label
};

struct TrunkRib {
  TrunkSide side = TrunkSide::right;
  int number = 0;                     // 8..12: its head articulates with vertebra T<number>
  std::vector<Vec3d> points;          // its centre line from the head outward (a polyline)
  double radius = 0.0;                // the bone's radius about the centre line
  std::optional<Vec3d> mid_axillary;  // where the centre line crosses the MAL's plane
  std::uint8_t label = 0;
};

struct TrunkIntercostalSpace {
  TrunkSide side = TrunkSide::right;
  int upper_rib = 0;
  std::optional<Vec3d> skin_point;
  std::optional<Vec3d> normal;
  std::string reason;  // why the point is absent
};

struct TrunkIliacCrest {
  TrunkSide side = TrunkSide::right;
  Vec3d top;
  Vec3d anterior_superior_spine;  // the crest's anterior end (centre of its end)
  std::uint8_t label = 0;         // the hip bone's
};

struct TrunkLumbarInterspace {
  std::string name;  // "L1/L2".."L5/S1"
  Vec3d skin_point;
  Vec3d normal;
};

struct TrunkFemoralPulse {
  TrunkSide side = TrunkSide::right;
  Vec3d skin_point;
  Vec3d normal;
  Vec3d artery_centre;  // the artery's centre line under the skin point
  double artery_radius = 0.0;
};

struct TrunkTruth {
  std::vector<TrunkVertebra> vertebrae;  // inferior to superior: S, L5..L1, T12..T8
  std::vector<TrunkRib> ribs;            // right 8..12, then left 8..12
  std::vector<TrunkIntercostalSpace> intercostal_spaces;  // right 8..11, left 8..11
  std::vector<TrunkIliacCrest> iliac_crests;              // right, left
  double tuffier_z = 0.0;
  std::string tuffier_level;
  std::vector<TrunkLumbarInterspace> lumbar_interspaces;  // L1/L2 .. L5/S1
  std::vector<TrunkFemoralPulse> femoral_pulses;          // right, left
  Vec3d symphysis;                                        // the pubic symphysis's front, midline
  std::vector<std::string> notes;                         // what is not shown, as sentences
};

// The truth for make_phantom("trunk", options) (UsageError as make_phantom for bad options).
TrunkTruth trunk_truth(const PhantomOptions& options = {});

// The bones' labels in PhantomTruth::bone_label: 0 none; 8..12 T8..T12, 13..17 L1..L5, 18 the
// sacrum, 19 the coccyx, 20 + N the right rib N, 40 + N the left, 60/61 the right/left hip bone
// (ilium, ischium, pubis), 62/63 the right/left femur. Name: "T8", "L3", "sacrum", "coccyx",
// "rib 9 right", "hip right", "femur left"; "" for 0 or an unused label.
std::string trunk_label_name(std::uint8_t label);

}  // namespace palp
