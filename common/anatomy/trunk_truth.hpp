// The trunk phantom's truth as anatomy::Landmarks (io/phantom_trunk.hpp defines every point):
// what landmark detection on `phantom:trunk[,options]` is tested against. Header-only, so that
// palp::io need not depend on the anatomy code. Confidence 1 for every landmark the volume shows;
// what it cannot show (the 11th intercostal space at the mid-axillary line, a landmark outside a
// thin slab) is absent with its reason.
#pragma once

#include <string>

#include "anatomy/landmarks.hpp"
#include "io/phantom_trunk.hpp"

namespace palp::anatomy {

inline Side to_side(TrunkSide side) {
  return side == TrunkSide::right ? Side::right : Side::left;
}

inline Landmarks trunk_landmarks(const TrunkTruth& truth, std::string scene = "phantom:trunk") {
  Landmarks out;
  out.scene = std::move(scene);
  out.notes = truth.notes;
  for (const TrunkRib& r : truth.ribs)
    out.ribs.push_back({to_side(r.side), r.number, r.points, 1.0, ""});
  for (const TrunkIntercostalSpace& s : truth.intercostal_spaces) {
    out.intercostal_spaces.push_back(
        {to_side(s.side), s.upper_rib, s.skin_point, s.normal, s.skin_point ? 1.0 : 0.0, s.reason});
  }
  for (const TrunkVertebra& v : truth.vertebrae)
    out.vertebrae.push_back({v.name, v.body_centre, v.spinous_tip, 1.0, ""});
  for (const TrunkIliacCrest& c : truth.iliac_crests)
    out.iliac_crests.push_back({to_side(c.side), c.top, 1.0, ""});
  out.tuffier_line = {truth.tuffier_z, truth.tuffier_level, 1.0, ""};
  for (const TrunkLumbarInterspace& l : truth.lumbar_interspaces)
    out.lumbar_interspaces.push_back({l.name, l.skin_point, l.normal, 1.0, ""});
  for (const TrunkFemoralPulse& f : truth.femoral_pulses)
    out.femoral_pulse_points.push_back(
        {to_side(f.side), f.skin_point, f.normal, "artery", 1.0, ""});
  return out;
}

// The truth for make_phantom("trunk", options), in the LPS world of the grid it draws (the same
// whatever `orient` says).
inline Landmarks trunk_landmark_truth(const PhantomOptions& options = {}) {
  return trunk_landmarks(trunk_truth(options));
}

}  // namespace palp::anatomy
