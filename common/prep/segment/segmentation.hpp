// Body (skin) and bone masks from a CT in HU (spec "Masks and distance maps").
//
// Orientation: the axial (slice) axis and the posterior axis are taken from Grid::world (LPS);
// with an identity direction, k is the slice axis and the table lies toward large j.
//
// Body: threshold; per axial slice, remove thin wide bands below the patient (table board, pad,
// mattress, cables lying on them), also where a pad touches the back; keep the 3D parts that are
// large and have a core deeper than body_core_radius_mm (torso, arms); fill internal air slice by
// slice (lungs and bowel gas that reach the first or last slice stay inside).
// Bone: seeds at high HU grown into lower-HU bone inside the body, and superficial rods of rib
// width that reach only the growing level (ribs a soft kernel or thick slices blurred); medium-HU
// regions that touch bone only across a narrow contact (contrast-filled vessels, enhancing organs)
// are dropped with that contact, and so are thick lumens of seed-level contrast below cortical HU
// that rest on the cortex along a strip; marrow filled where two of the three orthogonal slice
// planes find it enclosed, where bone brackets it along most lines through it, and in small
// cavities enclosed in 3D; the edge trimmed to a partial-volume level; notches narrower than a
// voxel filled; small islands and compact detached ones (calculi) removed.
#pragma once

#include <cstdint>

#include "base/volume.hpp"

namespace palp {

struct SegmentationParams {
  // Body: voxels above this HU are "not air".
  double body_threshold_hu = -500.0;
  // Connected parts of the body smaller than this are dropped (cables, clothing, table bits).
  double min_body_part_ml = 50.0;
  // A body part must hold at least one voxel whose in-slice neighbourhood of this radius is all
  // "not air" (thin shells and sheets are not patient).
  double body_core_radius_mm = 5.0;
  // Table detection: below the patient, bands at most this thick (along the posterior axis) and at
  // least this wide (and twice as wide as thick) are table, pad, mattress or cables.
  double max_table_thickness_mm = 50.0;
  double min_table_width_mm = 40.0;

  // Bone: seeds at or above bone_seed_hu, grown into neighbours at or above bone_grow_hu.
  double bone_seed_hu = 300.0;
  double bone_grow_hu = 150.0;
  // A grown region below bone_seed_hu that touches the seeds' rim with fewer than this fraction of
  // its voxels is a leak (a contrast-filled vessel or organ resting on bone) and is dropped.
  double bone_leak_contact_fraction = 0.05;
  // Lumens: contrast-filled vessels bright enough to seed (arterial phase, angiography) that rest
  // on bone (common/prep/bone/bone_lumens.hpp). The cortex level is bone_seed_hu +
  // bone_lumen_cortex_margin_hu (700 HU nominal, moving with the seed level): only cortical bone
  // reaches it, a lumen's 300-600 HU do not. A piece of the seeded regions from the seed level to
  // below it that touches the cortex along fewer than bone_lumen_max_contact of its surface
  // voxels (seed-level marrow is enclosed by its cortex) loses its opening by a ball of
  // bone_lumen_radius_mm: the thick part, a lumen 14 mm or more across (the aorta, the vena cava);
  // a rib or cortex holds no such ball. 5 mm took bone of the shared CT at 6 mm slices (recall
  // 0.838 -> 0.826; docs/notebook/prep.md). bone_lumen_radius_mm 0: off.
  double bone_lumen_cortex_margin_hu = 400.0;
  double bone_lumen_max_contact = 0.5;
  double bone_lumen_radius_mm = 7.0;
  // Marrow: a voxel is filled when at least bone_marrow_votes of the three orthogonal slice planes
  // through it (axial, coronal, sagittal) find it enclosed by the bone after a 3x3 closing (a hole
  // of at most bone_max_hole_mm2, or a voxel the closing adds). Marrow is enclosed in all three,
  // the spinal canal only in axial slices (common/prep/bone/bone_marrow.hpp).
  int bone_marrow_votes = 2;
  double bone_max_hole_mm2 = 3000.0;
  // Marrow between cortices: a voxel outside the bone is filled when bone brackets it (on both
  // sides, each within bone_enclosure_radius_mm) along at least bone_enclosure_directions of the
  // 13 lines through it: the sacrum, the pelvis between its cortices, a femoral head, open in
  // every plane (common/prep/bone/bone_enclosure.hpp). 0 directions: off.
  double bone_enclosure_radius_mm = 12.0;
  int bone_enclosure_directions = 10;
  // Marrow of a plate between cortices farther apart (the sacrum): also filled when bone brackets
  // it within bone_plate_radius_mm along as many lines AND along the line across the slices (the
  // body axis). The spinal canal, a tube open along the axis, is not bracketed along it however
  // far its arches reach. 0 (or not above bone_enclosure_radius_mm): off.
  double bone_plate_radius_mm = 20.0;
  // Edge trim: a bone voxel beside non-bone, next to a thicker bone voxel, is dropped when its HU
  // is below this fraction of the way from its outside neighbours' mean to its brightest bone
  // neighbour; 0: no trim. The half-maximum (0.5) fits sharp phantom edges but cuts ribs and
  // cortex the experts label on the shared CT (0 fits those best); 0.3 is the compromise: 0.2 gains
  // 0.003 Dice there and loses 0.015-0.019 on the torso phantom (docs/notebook/prep.md). The
  // contact a dropped leak leaves on a bone goes with the leak, whatever this is.
  double bone_edge_fraction = 0.3;
  // Notches: after the edge trim, a body voxel outside the bone with bone on at least this many of
  // its six faces (a pit, tunnel or gap narrower than a voxel in a surface smooth at that scale) is
  // the bone's partial volume and is filled, until none is left. 4 (more faces on bone than off),
  // 5 or 6; 0: off. A canal, foramen, disc or joint two voxels across never has four bone faces.
  int bone_notch_faces = 4;
  // Marrow behind a lumen (segment_bone's not_bone) resting on a cortex the scan blurs: the
  // marrow rules run a second time with the lumen's voxels beside bone counted as its shell;
  // what they add beside the lumen stays the lumen's edge (bone_segmentation.cpp).
  bool bone_marrow_behind_lumens = true;
  // Regions outside the bone that the bone encloses in 3D and that hold at most this are filled.
  double bone_max_cavity_ml = 30.0;
  // Bone islands smaller than this are removed.
  double min_bone_island_ml = 0.5;
  // Calculi: an island other than the largest that does not reach the scan's border, is shorter
  // than this along its principal axis, is compact (neither rod nor plate: its longest spread under
  // 3 times its thinnest) and lies more than a joint gap (6 mm) from other bone is a stone, a
  // calcified node or a phlebolith, not bone, and is removed: every bone of the trunk the scan
  // shows apart is long (a rib or cartilage segment, an arm's bone), flat, cut by the scan's edge
  // or across a joint from its neighbour (common/prep/bone/bone_islands.hpp). 0: off.
  double bone_calculus_max_length_mm = 30.0;
  // Skin clearance: bone lies under the skin (1.5-3 mm thick) and the fat or muscle beneath it, so
  // no body voxel within this distance of the outside (along each axis, at least one voxel) seeds
  // or grows bone. A sharp (bone) reconstruction kernel overshoots at the skin-air edge, and the
  // skin reads 200-450 HU there: without this a shell of "bone" forms under the skin (the shared
  // CT with its edges sharpened: docs/prep.md). The scan's own border is not outside. 0: off.
  double bone_skin_clearance_mm = 2.0;
  // Ribs without a seed: a softer kernel or thicker slices lower a thin rib's peak under the seed
  // level. A region of growable voxels that holds no seed is bone when it is a rod of rib width,
  // lies beside no gas (common/prep/bone/bone_ribs.hpp) and each of its voxels lies within this
  // distance of the body's outside in its slice plane, where ribs and costal cartilage lie and
  // contrast vessels or fluid-filled tubes of the same HU do not. 25 mm lost ribs of the shared CT
  // with its kernel softened, 40-60 mm took a sharpened kernel's overshoot
  // (docs/notebook/prep.md). 0: off.
  double bone_rib_depth_mm = 30.0;
};

struct SegmentationStats {
  std::uint64_t body_voxels = 0;
  std::uint64_t bone_voxels = 0;
  std::uint64_t removed_non_patient_voxels = 0;  // above the body threshold but not body
  std::uint64_t table_voxels = 0;                // of which recognised as table bands
};

// Everything that is not outside air, minus objects that are not the patient. 0/1, CT grid.
// Throws UsageError for unusable parameters.
Mask segment_body(const CtVolume& ct, const SegmentationParams& params,
                  SegmentationStats* stats = nullptr);

// Threshold + region growing inside `body`, marrow filled, small islands removed. 0/1.
// `not_bone` (optional, same grid): voxels known to be something else — contrast-filled lumens
// (prep/vessel/vessel_segmentation.hpp) — that neither seed nor grow bone, nor are filled later.
// Throws UsageError for unusable parameters or when a mask is not on the CT's grid.
Mask segment_bone(const CtVolume& ct, const Mask& body, const SegmentationParams& params,
                  SegmentationStats* stats = nullptr, const Mask* not_bone = nullptr);

// The index axes of a grid in patient terms, from its world direction (LPS).
struct PatientAxes {
  int slice = 2;      // axis closest to superior
  int posterior = 1;  // axis closest to posterior (the table side of a supine patient)
  int lateral = 0;
  bool posterior_increasing = true;  // index grows toward the back
};
PatientAxes patient_axes(const Grid& grid);

}  // namespace palp
