// The torso's `structures` option (phantom.hpp): the liver's inferior edge below the costal
// margin, and the groin's vessels (external iliac and femoral arteries, femoral veins), for the
// truth masks the force model's structure layers are made from.
#include <array>
#include <vector>

#include "io/phantom_torso_anatomy.hpp"

namespace palp::phantom_detail {
namespace {

// The groin, compressed along z to fit the field of view (whose last slice is at z = -95 mm, 27 mm
// below the aorta's bifurcation): the common iliacs divide 1 mm below the bifurcation, the
// external iliacs run forward and outward almost in the bifurcation's slices to the inguinal point
// 1 mm lower still, and the femoral arteries descend from there inferomedially, 15 mm under the
// anterior skin, at 54.5 degrees from the body axis (a course of 20 degrees in a groin four
// times as long) to z = -100 mm, then straight down.
constexpr double kIliacDivisionZ = kAortaBifurcationZ - 1.0;
constexpr double kInguinalZ = kIliacDivisionZ - 1.0;
constexpr double kFemoralBendZ = -100.0;
constexpr double kFemoralLateral = 72.0;  // the inguinal point's distance from the midline
constexpr double kFemoralDrift = 1.4;     // mm toward the midline per mm of descent
constexpr double kFemoralDepth = 15.0;    // centre line under the skin, along y
constexpr double kArteryR = 4.0, kVeinR = 5.0;
// The femoral vein beside the artery, toward the midline: 19 mm along x, 11 mm between the
// centre lines across the oblique run, a 2 mm gap between the walls.
constexpr double kVeinMedial = 19.0;

// The femoral run's centre line of one side (-1 the patient's right, +1 the left), `medial` mm
// closer to the midline, at kFemoralDepth under the skin: the inguinal point, the middle of the
// oblique run and its bend (two segments follow the skin's curve within 0.4 mm).
std::array<Vec3, 3> femoral_line(double side, double medial) {
  std::array<Vec3, 3> points{};
  const std::array<double, 3> z{kInguinalZ, (kInguinalZ + kFemoralBendZ) / 2.0, kFemoralBendZ};
  for (std::size_t n = 0; n < points.size(); ++n) {
    const double lateral = kFemoralLateral - medial - kFemoralDrift * (kInguinalZ - z[n]);
    const double x = kBodyCx + side * lateral;
    points[n] = {x, anterior_skin_y(x) + kFemoralDepth, z[n]};
  }
  return points;
}

// The femoral vessel of one side along its line: two oblique tubes, then straight down.
void add_femoral(std::vector<Layer>& layers, double side, double medial, double radius, double hu,
                 Tissue tissue) {
  const std::array<Vec3, 3> p = femoral_line(side, medial);
  layers.push_back({Tube{p[0], p[1], radius}, hu, tissue});
  layers.push_back({Tube{p[1], p[2], radius}, hu, tissue});
  layers.push_back(
      {EllipticCylinder{p[2][0], p[2][1], radius, radius, -kInfinity, kFemoralBendZ}, hu, tissue});
}

// Where the common iliac of one side divides: its centre line at kIliacDivisionZ.
Vec3 iliac_division(double side) {
  const Tube c = common_iliac(side);
  const double t = (c.a[2] - kIliacDivisionZ) / (c.a[2] - c.b[2]);
  return {c.a[0] + t * (c.b[0] - c.a[0]), c.a[1] + t * (c.b[1] - c.a[1]), kIliacDivisionZ};
}

}  // namespace

// The right lobe's anterior inferior part, along the front of the abdominal cavity below the
// lowest rib: its front 34 mm under the skin at x = kBodyCx - 55 (where no rib reaches), 3.7 mm
// behind the cavity's front, from z = 18 (inside the liver) down to its edge at z = -50 mm.
void add_liver_edge(std::vector<Layer>& layers, const TorsoLevels& levels) {
  layers.push_back({Ellipsoid{{kBodyCx - 55.0, kBodyCy - 46.0, -16.0}, {30.0, 18.0, 34.0}},
                    levels.liver, Tissue::kLiver});
}

void add_aorta_to_bifurcation(std::vector<Layer>& layers, const TorsoLevels& levels) {
  const Tissue artery = vessel_tissue(true, levels.artery);
  layers.push_back(
      {EllipticCylinder{kAortaCx, kAortaCy, kAortaR, kAortaR, kAortaBifurcationZ, kInfinity},
       levels.artery, artery});
  for (double side : {1.0, -1.0}) layers.push_back({common_iliac(side), levels.artery, artery});
}

// Veins first (the infrarenal IVC's level; their iliac veins are not drawn: the IVC ends below
// the inguinal level in this compressed pelvis), then the arteries at the arteries' level.
void add_groin_vessels(std::vector<Layer>& layers, const TorsoLevels& levels) {
  for (double side : {-1.0, 1.0})
    add_femoral(layers, side, kVeinMedial, kVeinR, levels.ivc_lower,
                vessel_tissue(false, levels.ivc_lower));
  const Tissue artery = vessel_tissue(true, levels.artery);
  for (double side : {-1.0, 1.0}) {
    layers.push_back(
        {Tube{iliac_division(side), femoral_line(side, 0.0)[0], kArteryR}, levels.artery, artery});
    add_femoral(layers, side, 0.0, kArteryR, levels.artery, artery);
  }
}

}  // namespace palp::phantom_detail
