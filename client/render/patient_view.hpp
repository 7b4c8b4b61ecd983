// Where palpview's camera stands in patient terms: the six standard views (from anterior,
// posterior, left, right, superior, inferior), placed through the scene's direction matrix so
// "anterior" shows the patient's front however the CT was stored, and the name of the view the
// camera is nearest to for the HUD. Pure: no VTK.
//
// Conventions (radiology): from anterior, posterior, left or right the patient's head is up; from
// superior or inferior, anterior is up. From anterior the patient's right is on the viewer's left.
#pragma once

#include <array>
#include <string>

#include "base/patient_frame.hpp"
#include "base/vec.hpp"

namespace palp::view {

struct CameraPlacement {
  Vec3d position{};  // scene frame, mm
  Vec3d focal{};
  Vec3d up{};
};

// The camera `distance` mm from `centre` on the patient's `from` side, looking at `centre`.
CameraPlacement patient_view(const PatientFrame& frame, Anatomy from, const Vec3d& centre,
                             double distance);

// The name of the view a camera looking along `direction_of_projection` (scene frame) shows:
// "anterior" when it looks from within 10 degrees of the patient's anterior, else the two
// nearest, e.g. "anterior-left".
std::string view_name(const PatientFrame& frame, const Vec3d& direction_of_projection);

// The six views in the order the V key cycles through them.
inline constexpr std::array<Anatomy, 6> kViewCycle{Anatomy::Anterior,  Anatomy::Left,
                                                   Anatomy::Posterior, Anatomy::Right,
                                                   Anatomy::Superior,  Anatomy::Inferior};

}  // namespace palp::view
