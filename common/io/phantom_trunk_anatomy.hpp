// Internal to the trunk phantom's sources: its anatomy as geometry (anatomy frame, mm: x =
// patient left, y = posterior, z = superior, the default field of view 400 x 300 x 561 mm centred
// on the origin). Both the drawing (phantom_trunk_skeleton.cpp, phantom_trunk.cpp) and the truth
// (phantom_trunk_truth.cpp) read it, so the landmarks are where the bones are drawn. Not part of
// palp::io's interface.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <variant>
#include <vector>

#include "base/vec.hpp"
#include "io/phantom_paint.hpp"

namespace palp::phantom_detail::trunk {

// A point as the paint shapes take it.
inline Vec3 to_array(const Vec3d& v) {
  return {v.x, v.y, v.z};
}

inline constexpr Vec3 kReferenceFov{400.0, 300.0, 561.0};
// The body: an elliptic cross-section centred at (0, kBodyCy), half-depth kBodyB, half-width
// body_half_width(z); the back rests on the pad at y = kBodyCy + kBodyB.
inline constexpr double kBodyCy = -25.0, kBodyB = 105.0;
inline constexpr double kPadTop = kBodyCy + kBodyB;
inline constexpr double kRibRadius = 5.0, kRibMarrowRadius = 3.0;
inline constexpr double kSpinousRadius = 4.0;
inline constexpr double kCrestRadius = 6.0;
inline constexpr double kArteryRadius = 4.5;

// Labels (phantom_trunk.hpp).
inline constexpr std::uint8_t kLabelSacrum = 18, kLabelCoccyx = 19;
inline std::uint8_t rib_label(int side, int number) {
  return static_cast<std::uint8_t>((side < 0 ? 20 : 40) + number);
}
inline std::uint8_t hip_label(int side) {
  return side < 0 ? 60 : 61;
}
inline std::uint8_t femur_label(int side) {
  return side < 0 ? 62 : 63;
}

// The anatomy frame of a trunk grid (LPS, identity direction): centred on the volume, scaled
// down to fit a smaller field of view in x and y, the pad's top face between two voxel rows.
AnatomyFrame trunk_frame(const Grid& grid);

double body_half_width(double z);
// The skin's outward unit normal at a point on (or near) the body's surface.
Vec3d skin_normal(const Vec3d& p);
// The skin point reached from p along +y (posterior, sign +1) or -y (anterior, -1).
Vec3d skin_along_y(const Vec3d& p, double sign);
// The mid-axillary point at level z on a side (-1 right, +1 left).
Vec3d mid_axillary_skin(double z, int side);

struct VertebraGeometry {
  std::string name;  // "L5" .. "T8"
  std::uint8_t label = 0;
  bool thoracic = false;
  double z_lo = 0.0, z_hi = 0.0;       // the body's endplates
  double y = 0.0, ax = 0.0, ay = 0.0;  // body centre y, half width, half depth
  double canal_y = 0.0, canal_ax = 0.0, canal_ay = 0.0;
  double transverse = 0.0, transverse_back = 0.0;  // process tip: x = +-transverse, canal_y + back
  Vec3d spinous_start, spinous_dir;                // middle centre line: start, unit direction
  double spinous_length = 0.0;                     // to the centre of its distal end
  double zc() const { return (z_lo + z_hi) / 2.0; }
  Vec3d body_centre() const { return {0.0, y, zc()}; }
  Vec3d spinous_tip() const {
    return spinous_start + spinous_dir * (spinous_length + kSpinousRadius);
  }
};
// Inferior to superior: L5, L4, ..., L1, T12, ..., T8 (the sacrum below, phantom's sacrum()).
const std::vector<VertebraGeometry>& vertebrae();
inline constexpr double kSacrumTopZ = -50.0;  // S1's superior endplate (the L5/S1 disc above)
// "L4" when z lies in a body, "L4/L5" in the disc between (the nearest one otherwise).
std::string vertebral_level(double z);

struct RibGeometry {
  int side = -1;  // -1 right, +1 left
  int number = 8;
  std::vector<Vec3d> points;  // centre line: head, then along the ring
  int mid_axillary_index =
      -1;  // the point on the MAL's plane (y = kBodyCy), -1 when it ends before
};
const std::vector<RibGeometry>& ribs();

// The sacrum as frusta along its tilted axis, and the pelvis's landmarks.
struct Frustum {  // elliptic cross-section about the axis a -> b in the plane x = cx
  double cx;
  Vec3d a, b;
  double wa, wb;  // lateral (x) half width at a and b
  double da, db;  // half depth (perpendicular to the axis, in the sagittal plane) at a and b
};
struct PelvisGeometry {
  Frustum sacrum_body, sacrum_alae;
  Vec3d s1_crest_start, s1_crest_tip;       // the first median sacral crest's tubercle (a tube)
  std::array<std::vector<Vec3d>, 2> crest;  // [0] right, [1] left: the crest's centre line,
                                            // from the ASIS back to the PSIS
  std::array<Vec3d, 2> crest_top;           // the top of the crest's bone
  std::array<Vec3d, 2> asis;                // the crest's anterior end (its centre)
  std::array<Vec3d, 2> femoral_head;        // centres
  Vec3d symphysis;                          // front of the symphysis, midline
  std::array<std::vector<Vec3d>, 2> femoral_artery;  // external iliac to the bottom
  std::array<Vec3d, 2> inguinal_artery;  // the artery's centre under the inguinal ligament
};
const PelvisGeometry& pelvis();

// The iliac wing's shell (one side): an elliptic shell about (0, cy) with half axes (A, B) at and
// above z_narrow, shrinking linearly to (A_low, B_low) at z_low; from angle t0 (anterior) to t1
// (posterior) (t = atan2((y - cy) / B, |x| / A)), between z_bottom(t) and z_top(t).
struct IliacShell {
  int side = -1;
  double cy = -35.0, a = 140.0, b = 85.0, a_low = 100.0, b_low = 62.0;
  double z_narrow = -70.0, z_low = -130.0;
  double t0 = 0.0, t1 = 0.0, t_peak = 0.0;
  double z_peak = 0.0, k_front = 0.0, k_back = 0.0;  // z_top = z_peak - k (t - t_peak)^2
  double z_bottom_front = -125.0, z_bottom_back = -115.0;
  double half_thickness = 4.5;
  double half_a(double z) const;
  double half_b(double z) const;
  double z_top(double t) const;
  double z_bottom(double t) const;
  Vec3d at(double t, double z) const;  // the shell's middle surface
};
IliacShell iliac_shell(int side);

// The trunk's bone and soft-tissue layers in paint order (phantom_trunk_skeleton.cpp builds the
// bones, phantom_trunk.cpp the rest).
struct Loft {  // the body's cross-section, inset by `inset` mm
  double inset;
  RowSpans spans(const RowContext& row) const;
  double coverage(double x, const RowContext& row, double row_factor) const;
};
struct ShellShape {
  IliacShell shell;
  RowSpans spans(const RowContext& row) const;
  double coverage(double x, const RowContext& row, double row_factor) const;
};
struct FrustumShape {
  Frustum f;
  RowSpans spans(const RowContext& row) const;
  double coverage(double x, const RowContext& row, double row_factor) const;
};
using TrunkShape =
    std::variant<EllipticCylinder, Ellipsoid, Box, Tube, Loft, ShellShape, FrustumShape>;

struct TrunkLayer {
  TrunkShape shape;
  double hu;
  Tissue tissue;
  std::uint8_t label = 0;
  double z_min = -kInfinity, z_max = kInfinity;  // no voxel outside this range is touched
};
TrunkLayer make_layer(const TrunkShape& shape, double hu, Tissue tissue, std::uint8_t label = 0);

void add_skeleton(std::vector<TrunkLayer>& layers);

}  // namespace palp::phantom_detail::trunk
