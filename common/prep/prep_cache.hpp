// prep's scene cache (internal to prep): what makes a result reusable. A result is keyed by a
// hash of the algorithm's version, every parameter that changes the outputs (also recorded in
// prep.json) and the input's bytes; it is reused only when prep.json names that key and every
// output has the size prep.json recorded.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "prep/prep.hpp"

namespace palp {

// Bump when the algorithms change what prep writes, so old caches are not reused.
// 2: oblique inputs reoriented, cube phantom ILA; 3: sub-voxel surfaces; 4: the bone trim keeps
// bone too thin for an interior voxel; 7: bone grown from 150 HU, marrow by votes of three planes,
// edge trim at 0.3; 8: marrow between cortices (bone_enclosure.cpp); 9: maps on a refined grid
// on coarse CTs (map_refine.hpp); 10: a leak's contact with the bone dropped with it; 11: marrow of
// plates bracketed within 20 mm and along the body axis (bone_enclosure.cpp); 12: notches
// narrower than a voxel filled after the edge trim (bone_notch_faces); 13: compact detached
// islands (calculi) removed (bone_calculus_max_length_mm, bone_islands.cpp); 14: the bone
// levels rise with the soft-tissue peak only as far as the fat peak confirms (hu_levels.cpp); 15:
// no bone within the skin clearance of the outside (bone_skin_clearance_mm); 16: the table also
// looked for in front of the patient (prone); 17: d_surf's skin projection in a canonical storage
// order (iso_projection.cpp: CTs stored other than LPS change); 18: thick contrast-filled lumens
// resting on the cortex removed (bone_lumens.cpp); 21: filled lumens apart from the skeleton
// removed (remove_lumen_islands: positive oral contrast, an arterial aorta away from the spine);
// 22: superficial rods of rib width that reach only the growing level kept as ribs (bone_ribs.cpp,
// bone_rib_depth_mm; 20 on its branch, before 21 was merged); 23: contrast-filled lumens found
// (prep/vessel), kept out of the bone and written as vessel.nii.gz / d_vessel.nii.gz; a body cut
// by the scan's back edge is not a table; the vessel search's cortex is a bright ridge and lumens
// as bright as no cancellous bone need no shell test; bone islands mostly on a lumen removed; 24:
// the table followed past an arm resting on the pad's end; 25: a lab's label map (--labels)
// gives the bone, the vessels and a <name>.nii.gz + d_<name>.nii.gz per organ or muscle, its
// bytes in the key; prep.json's structures record every structure's source and voxels; 26: a
// label map's arteries written as artery.nii.gz + d_artery.nii.gz, and a phantom drawn with
// `structures` gives its own artery and liver truth as structures; 29: the contrast phase from
// the veins beside the aorta (two trunk tubes side by side at its contrast: portal-venous; one:
// arterial), the aorta's level (arterial_above_soft_hu) only where no trunk is a tube; prep.json's
// vessel records second_trunk_level_hu; 38: where a lumen holds a tube, a part holding none and
// dimmer than it is an organ at any level; 39: a branch piece on the scan's end judged by the
// blood's level (the brightest lumen's mean or its tube core's, the larger; prep.json's vessel
// records tube_level_hu); 40: a part beside cortex along more than two thirds of its faces is
// marrow unless it averages cortical HU (docs/prep.md lists the rest)
inline constexpr int kPrepAlgorithmVersion = 40;

// Every parameter that changes the outputs: recorded in prep.json and part of the cache key.
nlohmann::json params_json(const PrepParams& params);

// True when out_dir holds a complete result of this cache key (its prep.json into *cached).
bool cache_is_valid(const std::filesystem::path& out_dir, const std::string& key,
                    nlohmann::json* cached);

}  // namespace palp
