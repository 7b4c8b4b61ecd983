// Tiny inline landmarks for the training tasks' tests (task, report, palp task): a torso with
// straight sloping ribs 5-12 on both sides, lumbar spinous tips 35 mm apart on the midline and
// both femoral pulse points, every number chosen so the tests compute their answers by hand.
#pragma once

#include "anatomy/landmarks.hpp"
#include "base/vec.hpp"

namespace palp::testing {

// Rib n's centre line at y (LPS: +y posterior) on a side: 40 mm deep to the skin at |x| = 170,
// sloping 0.2 mm down per mm towards anterior; ribs 25 mm apart (rib 9 at z = 75 at y = 0).
inline double rib_z(int n, double y) {
  return 300.0 - 25.0 * n + 0.2 * y;
}

inline palp::anatomy::Landmarks torso_landmarks() {
  using palp::Vec3d;
  using palp::anatomy::Side;
  palp::anatomy::Landmarks lm;
  lm.scene = "inline";
  for (const Side side : {Side::right, Side::left}) {
    const double x = side == Side::right ? -130.0 : 130.0;
    for (int n = 5; n <= 12; ++n) {
      palp::anatomy::Rib rib;
      rib.side = side;
      rib.number = n;
      rib.confidence = 1.0;
      // From the head (posterior, near the spine) outward, around the side to anterior; the
      // head folds medially (the part a side view would see twice).
      rib.points.push_back({x * 0.2, 100.0, rib_z(n, 100.0)});
      for (double y = 100.0; y >= -100.0; y -= 20.0) rib.points.push_back({x, y, rib_z(n, y)});
      lm.ribs.push_back(rib);
    }
    for (int n = 5; n <= 11; ++n) {
      palp::anatomy::IntercostalSpace space;
      space.side = side;
      space.upper_rib = n;
      space.skin_point = Vec3d{side == Side::right ? -170.0 : 170.0, 0.0,
                                     0.5 * (rib_z(n, 0.0) + rib_z(n + 1, 0.0))};
      space.normal = Vec3d{side == Side::right ? -1.0 : 1.0, 0.0, 0.0};
      lm.intercostal_spaces.push_back(space);
    }
  }
  // L1..L5 tips on the midline 35 mm apart (L3 at z = 95), the sacrum without a tip.
  const char* names[] = {"S", "L5", "L4", "L3", "L2", "L1"};
  for (int i = 0; i < 6; ++i) {
    palp::anatomy::Vertebra v;
    v.name = names[i];
    v.body_centre = {0.0, 20.0, 25.0 + 35.0 * (i - 1)};
    if (i > 0) v.spinous_tip = Vec3d{0.0, 80.0, 25.0 + 35.0 * (i - 1)};
    lm.vertebrae.push_back(v);
  }
  const char* gaps[] = {"L5/S1", "L4/L5", "L3/L4", "L2/L3", "L1/L2"};
  for (int i = 0; i < 5; ++i) {
    palp::anatomy::LumbarInterspace gap;
    gap.name = gaps[i];
    gap.skin_point = Vec3d{0.0, 90.0, 7.5 + 35.0 * i};
    gap.normal = Vec3d{0.0, 1.0, 0.0};
    lm.lumbar_interspaces.push_back(gap);
  }
  for (const Side side : {Side::right, Side::left}) {
    palp::anatomy::FemoralPulsePoint pulse;
    pulse.side = side;
    pulse.skin_point =
        Vec3d{side == Side::right ? -80.0 : 80.0, -100.0, -150.0};
    pulse.normal = Vec3d{0.0, -1.0, 0.0};
    pulse.source = "artery";
    lm.femoral_pulse_points.push_back(pulse);
  }
  return lm;
}

}  // namespace palp::testing
