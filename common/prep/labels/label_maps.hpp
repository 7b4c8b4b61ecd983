// Label maps a lab already has, as masks on the CT's grid: TotalSegmentator's `total` task (its
// multi-label NIfTI, `--ml`, or its folder of one <class>.nii.gz per class) and 3D Slicer
// segmentations (.seg.nrrd). See docs/labels.md.
//
// Bone classes make the bone mask; arteries and veins the vessel mask (with the split); organs and
// muscles a structure each, named by class (TotalSegmentator's names; a Slicer segment's name made
// a file name). A label map on another grid than the CT's is put on it nearest-neighbour through
// both world placements, with a note. Refused with a one-line InputError naming the file: a map
// that does not overlap the CT, class names palp cannot tell (a NIfTI without TotalSegmentator's
// label table and no class map given, a name outside the total task, a value no class or segment
// owns), values that are not whole numbers, a header that claims more data than the file holds,
// an empty map, an empty Slicer segment and an empty file TotalSegmentator was asked for
// (--roi_subset), files of a folder that label one voxel twice, and segment names that cannot
// become a file name. The label file is read slab
// by slab (label_volume.hpp). Memory: while reading, one byte per CT voxel (per Slicer layer) and
// at most 65 MiB; the result, the bone, artery, vein and vessel masks on the CT's grid and each
// organ's mask in its own box (a whole-body TotalSegmentator output has dozens of organs and
// muscles: a CT-sized mask each would take gigabytes).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "base/volume.hpp"

namespace palp {

struct LabelledStructure {
  std::string name;  // a file name: "liver", "kidney_left", "lung_right", "tumor", ...
  std::string kind;  // "organ" or "muscle" (prep adds "artery": prep/prep_structures.hpp)
  // 0/1 over the structure's box of CT voxels: voxel (i, j, k) is CT voxel offset + (i, j, k).
  // mask.grid is that box, placed in the world where those CT voxels are (the CT's spacing and
  // direction), so written as it is it overlays the CT; on_ct_grid() makes it CT-sized.
  Mask mask;
  Index3 offset{0, 0, 0};
  // {"file", "format", "classes": [the file's class or segment names], "resampled", "note"}
  nlohmann::json source;
};

struct LabelMaps {
  Mask bone;    // union of the bone classes; an empty grid (dims 0) when the file has none
  Mask vessel;  // artery ∪ vein ∪ vessels named neither; empty grid when none
  Mask artery;  // empty grid when none
  Mask vein;    // empty grid when none
  std::vector<LabelledStructure> organs;  // by name
  // The labelled vertebrae, sacrum and ribs (labels::skeleton_name), each its own value on the
  // CT's grid (one byte per voxel): value v is skeleton_names[v - 1] ("vertebrae_L3",
  // "rib_left_9", ...). Empty grid when the file has none. Their voxels are in `bone` too.
  Mask skeleton;
  std::vector<std::string> skeleton_names;
  // {"file", "format", "resampled", "structures": {name: {"kind", "classes", "voxels"}}, "notes"}
  nlohmann::json source;
  std::vector<std::string> notes;  // resampling, classes outside the CT, names palp guessed, ...
};

// The class map for a label volume that names no classes (a NIfTI without TotalSegmentator's
// header extension, a NRRD without Segment fields): empty refuses such a file;
// kTotalSegmentatorMap reads it as TotalSegmentator's `total` task (v2, 117 classes). A file that
// names its classes is read by its own names.
inline constexpr const char* kTotalSegmentatorMap = "totalsegmentator";
struct LabelMapOptions {
  std::string class_map;
};

// The structure's mask on the whole CT grid (one CT-sized allocation).
Mask on_ct_grid(const LabelledStructure& structure, const Grid& ct_grid);

// `path`: a .nii/.nii.gz (TotalSegmentator multi-label), a directory (TotalSegmentator's folder
// output), or a .seg.nrrd/.nrrd/.nhdr (3D Slicer). UsageError for an unknown class_map;
// InputError for the refusals above; ResourceError when the masks do not fit in memory.
LabelMaps read_label_maps(const std::string& path, const Grid& ct_grid,
                          const LabelMapOptions& options = {});

}  // namespace palp
