// Synthetic CTs in HU, for tests, benchmarks and the embedded default scene.
//   cube   — a block of soft tissue (+40 HU, 100 mm a side on the default 140^3 grid of 1 mm,
//            20 mm of air around it, -1000 HU), flat faces, no bone. Every face lies halfway
//            between voxel centres; the face a finger presses is the top face, +z (largest k),
//            at cube_geometry(grid).max[2].
//   sphere — a soft-tissue ball of analytic radius (30 mm on the default 100^3 grid of 1 mm) in
//            air, for distance error bounds; sphere_geometry gives its exact centre and radius.
//   torso  — the default scene: elliptic body (300 x 210 mm) with skin, fat and muscle, ribs with
//            intercostal spaces over a liver, a spine (vertebral bodies with cortex and marrow,
//            discs, arches around the canal, processes), lungs that reach the top slice, bowel
//            gas (one pocket crosses the bottom slice), a contrast-filled aorta touching the spine,
//            kidneys, an arm with its humerus beside the torso across a small air gap, and a CT
//            table below: a gel pad pressed against the back, a carbon board crossing the whole
//            width, and a cable lying on the pad. Edges carry partial-volume blending and a
//            deterministic +-10 HU noise. Default grid 384 x 256 x 96 at 1.25 x 1.25 x 2 mm.
//
// Orientation: sphere and torso are stored LPS: i = patient right -> left, j = anterior ->
// posterior (the table is at large j), k = inferior -> superior; Grid::world has the identity
// direction. The cube lies like a supine patient with its top face up: it is stored "ILA" (i =
// superior -> inferior, j = right -> left, k = posterior -> anterior), so its top face (+z) is
// its anterior and --side auto presses it. Every origin centres the volume on the isocentre.
// Anatomy is defined in mm; when the grid's field of view is smaller than the default one the
// anatomy is scaled down uniformly to fit (never up), so any dims/spacing override still shows the
// whole phantom.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "base/volume.hpp"

namespace palp {

struct PhantomOptions {
  // Override the phantom's default grid (dims and spacing); its anatomy scales in mm, not voxels,
  // so a finer grid draws the same body at higher resolution.
  std::optional<Index3> dims;
  std::optional<Vec3> spacing;
};

// Names accepted by make_phantom: "cube", "sphere", "torso".
std::vector<std::string> phantom_names();

// The grid make_phantom(name, options) draws on (defaults with the overrides applied).
// Throws UsageError for an unknown name or an unusable dims/spacing override.
Grid phantom_grid(const std::string& name, const PhantomOptions& options = {});

// Ground truth drawn together with the CT: the patient's body (skin and everything inside it,
// internal air included, no table/pad/cables), its bones (cortex and marrow) and the objects that
// are not the patient (table board, pad, cable; empty for cube and sphere). A voxel belongs to a
// structure when its centre does (partial-volume coverage >= 1/2).
struct PhantomTruth {
  Mask body;
  Mask bone;
  Mask equipment;
};

// Throws UsageError for an unknown name. When `truth` is given it receives the true masks.
CtVolume make_phantom(const std::string& name, const PhantomOptions& options = {},
                      PhantomTruth* truth = nullptr);

// Analytic facts the tests check against (scene frame, mm).
struct SphereGeometry {
  Vec3 centre;
  double radius;
};
SphereGeometry sphere_geometry(const Grid& grid);  // for the sphere phantom on `grid`

// The cube phantom's block: faces at min and max along each axis (scene frame, mm). Voxels whose
// centres lie inside are soft tissue, all others air.
struct BoxGeometry {
  Vec3 min;
  Vec3 max;
};
BoxGeometry cube_geometry(const Grid& grid);  // for the cube phantom on `grid`

}  // namespace palp
