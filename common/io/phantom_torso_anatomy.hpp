// Internal to the torso phantom's sources (phantom_torso.cpp, phantom_structures.cpp): where the
// torso's body, spine and aorta lie, the HU that the contrast options set, and the layers the
// `structures` option adds. Not part of palp::io's interface. Anatomy frame, mm: x = patient
// left, y = posterior, z = superior; the default field of view 480 x 320 x 192 mm is centred on
// the origin.
#pragma once

#include <cmath>
#include <vector>

#include "io/phantom_shapes.hpp"

namespace palp::phantom_detail {

inline constexpr Vec3 kTorsoReferenceFov{480.0, 320.0, 192.0};
inline constexpr double kBodyCx = 20.0, kBodyCy = -20.0;  // body centre
inline constexpr double kBodyA = 150.0, kBodyB = 105.0;   // half width, half depth
inline constexpr double kPadTop = kBodyCy + kBodyB;       // the back rests on the pad
inline constexpr double kSpineCy = kBodyCy + 45.0;        // vertebral body centre
inline constexpr double kCanalCy = kSpineCy + 24.0;       // spinal canal centre
inline constexpr double kVertebraPeriod = 32.0;
inline constexpr double kAortaCx = kBodyCx + 10.0, kAortaCy = kSpineCy - 25.5, kAortaR = 12.0;
inline constexpr double kAortaBifurcationZ = -68.0;
inline constexpr double kScrewZ = 8.0;  // the implant's vertebra (n = 0, centred in the view)

// HU of the organs and vessels that contrast changes. Without contrast options: today's default
// (aorta only, 250 HU). `tree`: the arterial branches and the veins are drawn too.
struct TorsoLevels {
  bool tree = false;
  double liver = 60.0, kidney = 150.0;
  double artery = 250.0;                                        // the aorta and its branches
  double ivc_upper = kSoftTissueHu, ivc_lower = kSoftTissueHu;  // above / below the renal veins
  double portal = kSoftTissueHu, renal_vein = kSoftTissueHu;
};

TorsoLevels torso_levels(const PhantomOptions& options);

// An artery's or a vein's tissue: contrast-filled when drawn kContrastAboveTissueHu above soft
// tissue.
Tissue vessel_tissue(bool artery, double hu);

// The common iliac artery of one side (-1 the patient's right, +1 the left): from the aorta's
// bifurcation down and outward to below the field of view (its far part is, for the structures,
// the internal iliac).
inline Tube common_iliac(double side) {
  return {{kAortaCx, kAortaCy, kAortaBifurcationZ}, {side < 0.0 ? 0.0 : 58.0, 4.0, -112.0}, 6.5};
}

// The anterior skin's y at x (the body ellipse's front), for |x - kBodyCx| < kBodyA.
inline double anterior_skin_y(double x) {
  const double u = (x - kBodyCx) / kBodyA;
  return kBodyCy - kBodyB * std::sqrt(1.0 - u * u);
}

// The `structures` option's layers (phantom_structures.cpp; phantom.hpp says what they are).
// The liver's inferior edge below the costal margin: painted after the bowel gas, before the
// vessels.
void add_liver_edge(std::vector<Layer>& layers, const TorsoLevels& levels);
// Without the vessel tree: the aorta down to its bifurcation and the common iliac arteries, at the
// aorta's level (instead of the lone aorta through the whole field of view).
void add_aorta_to_bifurcation(std::vector<Layer>& layers, const TorsoLevels& levels);
// The external iliac and femoral arteries and the femoral veins of both sides: painted last of
// the organs' layers.
void add_groin_vessels(std::vector<Layer>& layers, const TorsoLevels& levels);

}  // namespace palp::phantom_detail
