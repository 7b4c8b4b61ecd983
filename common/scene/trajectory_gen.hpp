// The paper's device trajectories, generated for a scene (deterministic pure functions).
//
// Conventions (scene frame, mm, s):
//   - The tool frame's +z points away from the skin: the pad (the centroid of the tool's contact
//     points, (0, 0, -pad_offset) for every palp tool) is pad_offset mm along -z from the device
//     point. A pose "at depth d" puts the pad centre d mm below the skin along the outward normal
//     n, i.e. where D_surf = d (d < 0: above the skin), with tool +z = n.
//   - Roll: tool +y is the slide direction projected onto the skin's tangent plane, +x = y × z.
//     On the cube's top face (n = +z, slide = +y) the orientation is the identity.
//   - Row i is at t = i / rate; a path of duration T has round(T * rate) + 1 rows.
//
// Paths on a flat frame (paper Fig. 4, on the cube phantom): a SurfaceAnchor (a skin point, its
// outward normal and a slide direction) fixes a plane; the lateral offset u (along the slide
// direction, centred on the anchor) and the depth are functions of time.
//   slide_ramp    u from -L/2 to +L/2 at constant speed, depth ramping linearly (Fig. 4a)
//   slide_speed   press to a depth at rest, slide at piecewise-constant speeds, hold (Fig. 4b)
//   press_hold    approach from above, press to a depth, optional lateral shift, hold with an
//                 optional deterministic jitter (the no-creep experiment)
// Path over a curved skin (paper Fig. 5a, on the torso phantom):
//   ribs_slide    along the body axis (inferior -> superior, across the ribs) over the lateral /
//                 anterior chest wall at a fixed depth, the tool aligned with the local skin
//                 normal at every row.
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

#include "base/vec.hpp"
#include "model/field_sampler.hpp"
#include "model/tool.hpp"
#include "scene/trajectory.hpp"

namespace palp {

// A point on the skin (D_surf = 0), the outward unit normal there and a unit tangent to slide
// along.
struct SurfaceAnchor {
  Vec3d point{};
  Vec3d normal{0.0, 0.0, 1.0};
  Vec3d slide{0.0, 1.0, 0.0};
};

// The side the tool comes from: a face of the grid (+x ... -z), or a patient direction resolved
// through the grid's direction matrix (base/patient_frame.hpp) to the grid face nearest to it.
enum class ApproachSide {
  Auto,
  PlusX,
  MinusX,
  PlusY,
  MinusY,
  PlusZ,
  MinusZ,
  Anterior,
  Posterior,
  Left,
  Right,
  Superior,
  Inferior,
};
// "auto", "+x", "-x", "+y", "-y", "+z", "-z", "anterior", "posterior", "left", "right",
// "superior", "inferior"; UsageError otherwise.
ApproachSide parse_approach_side(std::string_view text);
const char* to_string(ApproachSide side);

// The skin point hit by a ray along the grid's centre line, coming from `side` (the grid's face
// on that side inward). A patient side takes the face nearest to that direction and slides
// toward the patient's left (toward superior when it comes from the left or right). Auto is the
// patient's anterior, then right, left, superior, inferior and posterior: the first whose ray
// starts in air and reaches skin (the torso's anterior wall, the cube's top face, which is its
// anterior). A grid face (+x ... -z) slides along +y (z faces) or +x. InputError when no skin is
// found.
SurfaceAnchor find_surface_anchor(const FieldSampler& fields, ApproachSide side);

// Distance (mm) from the device point to the pad: minus the z of the contact points' centroid
// (8 for fingers, 50 for the probe). UsageError for a tool whose points do not lie below it.
double pad_offset(const Tool& tool);

// The orientation with tool +z = normal and tool +y = slide projected onto the tangent plane
// (any perpendicular when slide is parallel to the normal). Unit quaternion with w >= 0.
Quat surface_orientation(const Vec3d& normal, const Vec3d& slide);

// The device pose putting the pad centre at `pad_centre` with tool +z = normal.
Pose pad_pose(const Vec3d& pad_centre, const Vec3d& normal, const Quat& orientation,
              double pad_offset);

struct SlideRampSpec {
  double rate_hz = 1000.0;
  double duration_s = 6.0;
  double speed_mm_s = 10.0;  // lateral travel = speed * duration, centred on the anchor
  double depth_start_mm = 0.0;
  double depth_end_mm = 6.0;
};
Trajectory slide_ramp(const SurfaceAnchor& anchor, double pad_offset, const SlideRampSpec& spec);
void validate(const SlideRampSpec& spec);  // UsageError naming the option; generators call it

struct SlideSpeedSpec {
  double rate_hz = 1000.0;
  double depth_mm = 3.0;
  double press_s = 0.5;  // from depth 0 to depth_mm, at rest
  std::vector<double> speeds_mm_s{10.0, 40.0, 10.0};
  double segment_s = 1.0;  // time at each speed
  double hold_s = 0.5;     // at rest at the end
};
// The slide's travel is centred on the anchor.
Trajectory slide_speed(const SurfaceAnchor& anchor, double pad_offset, const SlideSpeedSpec& spec);
void validate(const SlideSpeedSpec& spec);

struct PressHoldSpec {
  double rate_hz = 1000.0;
  double approach_mm = 2.0;  // start this far above the skin
  double depth_mm = 4.0;
  double press_s = 1.0;   // from -approach_mm to depth_mm, linear
  double shift_mm = 0.0;  // lateral displacement along the slide direction after the press
  double shift_s = 0.5;
  double hold_s = 3.0;
  double jitter_mm = 0.0;  // during the hold: uniform in [-jitter, +jitter] on each tangent axis
  std::uint64_t seed = 1;  // of the jitter
};
Trajectory press_hold(const SurfaceAnchor& anchor, double pad_offset, const PressHoldSpec& spec);
void validate(const PressHoldSpec& spec);

enum class BodySide { Right, Left };  // the patient's
struct RibsSpec {
  double rate_hz = 1000.0;
  BodySide side = BodySide::Right;  // the liver side, where PTCD is palpated
  double azimuth_deg = 30.0;        // ray angle from lateral toward anterior, about the body axis
  double from = 0.25;               // start and end along the body axis, as fractions of the
  double to = 0.75;                 // grid's extent from its inferior end
  double speed_mm_s = 20.0;
  double depth_mm = 5.0;
  double approach_mm = 2.0;  // press from / lift back to this far above the skin
  double press_s = 0.5;      // duration of the press and of the lift
};
// Directions come from the grid's world placement (LPS): superior, patient right / left and
// anterior, each mapped to the nearest scene axis; the body axis passes through the centroid of
// the body (D_surf > 0) in the middle slice. InputError when the path leaves the body.
Trajectory ribs_slide(const FieldSampler& fields, double pad_offset, const RibsSpec& spec);
void validate(const RibsSpec& spec);

// The body axis of a ribs path: a line through the body's centroid in the middle slice, along
// the scene axis nearest to superior, and the ray (perpendicular to it) toward the skin.
struct BodyAxis {
  Vec3d centre{};       // centroid of D_surf > 0 in the middle slice
  int axis = 2;         // scene axis of the body axis
  Vec3d superior{};     // unit, along `axis`
  Vec3d ray{};          // unit, from the axis out toward the chest wall
  double extent = 0.0;  // grid extent along `axis`, mm
};
BodyAxis ribs_body_axis(const FieldSampler& fields, const RibsSpec& spec);

// Where ribs_slide puts the pad at one position along the body axis.
struct SkinFrame {
  Vec3d skin{};    // skin point on the ray
  Vec3d normal{};  // outward normal, averaged over a 5 x 5 mm patch around it
  Vec3d slide{};   // unit slide direction (superior)
};
// The skin frame at fraction `along` (0 = inferior end) of the body axis. InputError when the
// axis point is outside the body or the ray leaves the grid before reaching skin.
SkinFrame ribs_skin_frame(const FieldSampler& fields, const BodyAxis& axis, double along);

// The pad centre at `depth_mm` below the skin of `frame` along its normal, corrected so that
// D_surf there equals the depth (a few Newton steps along the normal).
Vec3d pad_centre_at_depth(const FieldSampler& fields, const SkinFrame& frame, double depth_mm);

}  // namespace palp
