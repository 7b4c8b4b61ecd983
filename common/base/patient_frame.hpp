// Which way the patient faces in the scene frame, from the file's direction matrix.
//
// The scene frame is the grid's index axes scaled by spacing (spec "Frames and units"); the
// file's direction matrix D (LPS, columns = the i, j, k directions) says where each index axis
// points in the patient. A patient direction w (LPS) is Dᵀw in the scene frame, so the rows of D
// are the patient's left, posterior and superior seen from the scene. Every place that needs
// "anterior" (the camera, --side auto, generated paths, table detection, docs) asks this file,
// never the voxel order: the same patient stored RAS, LPS, with reversed slices or permuted axes
// faces the same way.
//
// Orientation codes follow the "towards" convention of 3D Slicer and nibabel: "LPS" means i
// increases toward the patient's left, j toward posterior, k toward superior (DICOM's patient
// axes); "RAS" is NIfTI's canonical order.
#pragma once

#include <string>
#include <string_view>

#include "base/vec.hpp"
#include "base/volume.hpp"

namespace palp {

enum class Anatomy { Left, Right, Posterior, Anterior, Superior, Inferior };
const char* to_string(Anatomy direction);  // "left", "right", "posterior", ...
char letter(Anatomy direction);            // 'L', 'R', 'P', 'A', 'S', 'I'
Anatomy opposite(Anatomy direction);

// A signed index axis: +x is {0, +1}.
struct SignedAxis {
  int axis = 0;
  int sign = 1;
  bool operator==(const SignedAxis&) const = default;
};
std::string to_string(SignedAxis axis);  // "+x", "-y", ...

struct PatientFrame {
  // Unit vectors in the scene frame toward the patient's left, posterior and superior.
  Vec3d left{1.0, 0.0, 0.0};
  Vec3d posterior{0.0, 1.0, 0.0};
  Vec3d superior{0.0, 0.0, 1.0};

  // The unit scene-frame vector toward `direction`.
  Vec3d toward(Anatomy direction) const;
  // The index axis (and its sign) nearest to `direction`.
  SignedAxis nearest_axis(Anatomy direction) const;
  // The patient direction an index axis increases toward (the nearest of the six).
  Anatomy axis_direction(int axis) const;
  // Three letters, one per index axis: "LPS", "RAS", "LIP", ...
  std::string orientation_code() const;
  // The largest angle (degrees) between an index axis and the patient axis nearest to it: 0 for
  // an axis-aligned file, the gantry tilt or obliquity otherwise.
  double obliquity_deg() const;
};

// From the grid's world placement. A direction matrix that is not a rotation (non-orthonormal,
// non-finite, zero columns) gives the identity frame (LPS), as if the file carried none.
PatientFrame patient_frame(const Grid& grid);
PatientFrame patient_frame(const WorldPlacement& world);

// The patient (LPS world) point of a scene point: origin + D·x.
Vec3d world_of_scene(const Grid& grid, const Vec3d& scene_mm);
// The scene point of a patient point: Dᵀ (w − origin) (the direction is orthonormal).
Vec3d scene_of_world(const Grid& grid, const Vec3d& world_mm);

// Parses "anterior", "posterior", "left", "right", "superior", "inferior" (or A P L R S I).
// Returns false for anything else.
bool parse_anatomy(std::string_view text, Anatomy* out);

}  // namespace palp
