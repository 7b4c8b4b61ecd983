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
//            gas (one pocket crosses the bottom slice), a contrast-filled aorta (250 HU) touching
//            the spine, kidneys, an arm with its humerus beside the torso across a small air gap,
//            and a CT table below: a gel pad pressed against the back, a carbon board crossing the
//            whole width, and a cable lying on the pad. Edges carry partial-volume blending and a
//            deterministic +-10 HU noise. Default grid 384 x 256 x 96 at 1.25 x 1.25 x 2 mm.
//   trunk  — a supine adult trunk whose landmarks are known exactly (issue 40; its truth and the
//            definitions of every point: phantom_trunk.hpp): vertebrae T8..L5 (cortex 1000 HU,
//            marrow 250) with discs, arches, transverse and spinous processes, the sacrum and
//            coccyx; ribs 8-12 on both sides, each from its own vertebra around the side and
//            forward, descending (11 and 12 floating, 12 ending behind the mid-axillary line);
//            iliac wings with crests topping at the L4/L5 disc, anterior superior iliac spines,
//            pubic bones meeting at the symphysis, acetabula, femoral heads and proximal femora;
//            skin, fat and muscle (narrower at the waist), the lungs' bases, the liver under the
//            right lower ribs, kidneys, bowel gas; the aorta dividing on L4 into the iliac
//            arteries, the common femoral arteries under the inguinal ligament at the
//            mid-inguinal point 15 mm under the skin, femoral veins; a CT table (board and pad)
//            under the back. From 9.5 mm above T8's top to 130 mm below the femoral heads' centres:
//            default grid 160 x 120 x 187 at 2.5 x 2.5 x 3 mm (400 x 300 x 561 mm). Like the
//            torso, a smaller field of view in x and y scales it down, z never does; above T8
//            nothing but soft tissue is drawn. PhantomTruth::bone_label labels every bone.
//
// Orientation: sphere, torso and trunk are stored LPS: i = patient right -> left, j = anterior ->
// posterior (the table is at large j), k = inferior -> superior; Grid::world has the identity
// direction. The cube lies like a supine patient with its top face up: it is stored "ILA" (i =
// superior -> inferior, j = right -> left, k = posterior -> anterior), so its top face (+z) is
// its anterior and --side auto presses it. Every origin centres the volume on the isocentre. The
// `orient` option (any phantom) stores the same voxels in another axis order afterwards, the
// truth masks with them: the same patient at the same LPS world positions.
// Anatomy is defined in mm; when the grid's field of view is smaller than the default one the
// anatomy is scaled down uniformly to fit (never up), so any dims/spacing override still shows the
// whole phantom. Only x and y are fitted: along z the anatomy keeps its size in mm whatever the
// slice count or thickness, so a thin slab (e.g. dims 384x256x20) is the middle 20 slices' worth of
// the same torso, centred on the same level, and 5 mm slices (spacing 1.25x1.25x5) show more of it.
//
// Torso options (PhantomOptions; default: none of them, the scene above byte for byte; the trunk
// takes contrast, aorta_hu and structures too, the last only asking prep for its truth masks):
//   contrast      none | arterial | portal-venous: draws the vessel tree at that phase's levels
//                 instead of the lone aorta: the aorta down to its bifurcation (z = -68 mm) and
//                 the common iliac arteries, the coeliac trunk and superior mesenteric artery
//                 leaving it forward, the renal arteries into the kidneys; the inferior vena cava
//                 right of the aorta, the renal veins (the left one between the aorta and the
//                 SMA) and the portal vein up into the liver. HU (arteries / portal vein / IVC
//                 above, below the renal veins / renal veins / liver / kidneys):
//                   none           40 / 40 / 40, 40 / 40 / 55 / 35
//                   arterial       400 / 90 / 85, 40 / 95 / 60 / 150
//                   portal-venous  170 / 180 / 150, 130 / 160 / 100 / 160
//   aorta_hu      the arteries' HU (the aorta and its branches), the rest from `contrast`
//                 (arterial when not given): aorta 400 alone draws what contrast=arterial does.
//   arms          0, 1 (default: the right arm) or 2 (the left one too, mirrored about the body).
//                 With the vessel tree each arm has its brachial artery at the arteries' HU, 3 mm
//                 in radius, anteromedial to the humerus with 1 mm of tissue between them (closer
//                 than it mostly lies, as the subclavian rests on the first rib): a branch that
//                 both of the scan's ends cut off from its trunk, resting on bone.
//   level         the anatomy's z (mm) at the field of view's centre (default 0): where along
//                 the body the scan lies, e.g. a slab at level=-9 whose top slice cuts the SMA
//                 off from the aorta.
//   metal         a pair of pedicle screws (3 mm radius, 3500 HU) in the vertebra at z = 8 mm,
//                 with deterministic metal streaks in the slices through them: bright and dark
//                 rays of 300-800 HU from each screw, decaying with distance (about halving every
//                 40 mm), and a dark band between the screws, on the patient's voxels only.
//   dissection    the aorta dissected, as an early arterial phase shows it: a true lumen 14 mm
//                 across at the aorta's HU in its front, the false lumen filling the rest of
//                 the 24 mm vessel at soft-tissue HU + 10 (slow flow, not yet filled), in 4 mm
//                 of periaortic fat; both lumens are the truth vessel's (the aorta's lumen).
//                 With structures it needs contrast or aorta_hu (the tree's aorta)
//   structures    what a finger feels besides bone (issue 39), for the truth masks the force
//                 model's structure layers come from (prep writes them: artery.nii.gz,
//                 liver.nii.gz and their maps):
//                 - the groin's vessels. The field of view ends 27 mm below the aorta's
//                   bifurcation (z = -68 mm; the last slice's centre is at z = -95 mm), so the
//                   groin is compressed about fourfold along z: the common iliacs divide 1 mm
//                   below the bifurcation (their drawn course on is the internal iliac), the
//                   external iliac arteries (4 mm radius) run forward and outward almost within
//                   those slices to the inguinal point (z = -70 mm, 72 mm either side of the
//                   body's midline), and the femoral arteries (4 mm radius) descend from there
//                   inferomedially at 54.5 degrees from the body axis (what a 20-degree course
//                   becomes) with their centre line 15 mm under the anterior skin (along y) to
//                   z = -100 mm, then straight down: about 43 mm of each inside the default
//                   field of view. The femoral veins (5 mm radius) lie beside them toward the
//                   midline (11 mm between the centre lines), from the inguinal point down (their
//                   iliac veins are not drawn). Without the vessel tree (no contrast options) the
//                   aorta ends at its bifurcation too, with its common iliacs.
//                   HU: the arteries at the arteries' level (the lone aorta's 250 HU without
//                   contrast options), the femoral veins at the infrarenal IVC's (soft tissue
//                   without contrast options or in the arterial phase).
//                 - the liver's inferior edge below the right costal margin: a lobe along the
//                   front of the abdominal cavity (ellipsoid, centre 55 mm right of the midline,
//                   46 mm in front of the body's centre, z = -16 mm; semi-axes 30 x 18 x 34 mm)
//                   at the liver's HU. 55 mm right of the midline, where no rib reaches, the
//                   liver's front is 34 mm under the skin at the lowest rib's level (z = -22 mm
//                   at its front end, its lower border -26.5 mm), 35 mm at z = -29 mm, 42 mm at
//                   z = -45 mm, and its edge is at z = -50 mm; below, no liver.
//                 Everything else (and every slice above z = 20 mm) is the torso without it.
// On the command line: palp phantom torso --contrast arterial --aorta-hu 400 --arms 2 --metal
// --structures. In a CT input or scene (parse_phantom_spec): phantom:NAME[,KEY=VALUE...] with the
// keys dims, spacing, contrast, aorta-hu, arms, level, metal, structures, dissection, orient
// (metal, structures or dissection alone means =1), e.g. phantom:torso,contrast=arterial,arms=2,
// phantom:trunk,orient=RAS or phantom:torso,dims=384x256x20,spacing=1.25x1.25x1.5 or
// phantom:torso,structures.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "base/volume.hpp"

namespace palp {

enum class PhantomContrast { none, arterial, portal_venous };
const char* phantom_contrast_name(PhantomContrast contrast);  // "none", "arterial", "portal-venous"

struct PhantomOptions {
  // Override the phantom's default grid (dims and spacing); its anatomy scales in mm, not voxels,
  // so a finer grid draws the same body at higher resolution.
  std::optional<Index3> dims;
  std::optional<Vec3> spacing;
  // The torso's options (above); any of them on the cube or sphere is a UsageError.
  std::optional<PhantomContrast> contrast;
  std::optional<double> aorta_hu;  // [-1000, 3000]
  int arms = 1;                    // 0, 1 or 2
  bool metal = false;
  bool structures = false;
  bool dissection = false;  // torso: the aorta dissected (above)
  double level_mm = 0.0;    // torso: the anatomy's z at the field of view's centre, [-200, 200]
  // Any phantom: store it in this axis order (an orientation code, base/axis_order.hpp: "RAS",
  // "PIL", ...), the same patient in the same LPS world place; absent: the phantom's own order.
  std::optional<std::string> orient;
};

// Sets one option from its text: dims and spacing as NXxNYxNZ, contrast, aorta-hu, arms, metal
// (1/0, true/false, on/off, yes/no). Throws UsageError for an unknown key or a bad value.
void set_phantom_option(PhantomOptions& options, const std::string& key, const std::string& value);

// "NAME[,KEY=VALUE...]" (what follows "phantom:" in a CT input): the name and its options.
struct PhantomSpec {
  std::string name;
  PhantomOptions options;
};
PhantomSpec parse_phantom_spec(const std::string& text);

// Names accepted by make_phantom: "cube", "sphere", "torso", "trunk".
std::vector<std::string> phantom_names();

// The grid make_phantom(name, options) draws on (defaults with the overrides applied).
// Throws UsageError for an unknown name or an unusable dims/spacing override.
Grid phantom_grid(const std::string& name, const PhantomOptions& options = {});

// Ground truth drawn together with the CT: the patient's body (skin and everything inside it,
// internal air included, no table/pad/cables), its bones (cortex and marrow, and the metal
// implant: rigid, inside a vertebra) and the objects that are not the patient (table board, pad,
// cable; empty for cube and sphere). `vessel`: the lumens of the visibly contrast-filled vessels,
// arteries and veins, those drawn at least 60 HU above soft tissue (>= 100 HU; so in the arterial
// phase the arteries only, none without contrast, every drawn vessel in the portal-venous one).
// `artery`: the arteries' lumens whatever their HU (the aorta alone without contrast options;
// with `structures` the iliac and femoral arteries too). `metal`: the implant. `liver`: the
// liver's parenchyma (its portal vein is a vein; with `structures` its inferior edge's lobe too).
// A voxel belongs to a structure when its centre does (partial-volume coverage >= 1/2) and no
// later-painted structure (a vertebra over the aorta's back) covers it.
struct PhantomTruth {
  Mask body;
  Mask bone;
  Mask equipment;
  Mask vessel;
  Mask artery;
  Mask metal;
  Mask liver;
  // The trunk's bones, one label each (phantom_trunk.hpp's trunk_label_name); empty otherwise.
  Mask bone_label;
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
