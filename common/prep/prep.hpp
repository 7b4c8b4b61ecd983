// The preprocessing pipeline: CT -> body and bone masks -> signed distance maps, written as
//   body.nii.gz, bone.nii.gz (uint8 0/1), d_surf.nii.gz, d_bone.nii.gz (float32 mm), prep.json
// on the input grid voxel for voxel (spec "Files"; on a CT coarser than map_spacing_mm the two
// maps lie on its aligned refinement, map_refine.hpp). Results are cached by input content and
// parameters: a second run on the same input into the same directory only verifies the cache.
// With a lab's label map (labels_path), its bone, vessels and organs replace what prep segments,
// each organ or muscle written as <name>.nii.gz + d_<name>.nii.gz (prep_structures.hpp).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "base/volume.hpp"
#include "prep/maps/distance_transform.hpp"
#include "prep/maps/map_refine.hpp"
#include "prep/segment/hu_levels.hpp"
#include "prep/segment/segmentation.hpp"
#include "prep/vessel/vessel_segmentation.hpp"

namespace palp {

// Which surface the distance maps measure to (spec "Masks and distance maps"): the binary masks'
// voxel faces (`mask`), or the HU iso-surfaces inside the segmented components (`subvoxel`,
// prep/maps/subvoxel_distance.hpp).
enum class SurfaceMethod { subvoxel, mask };

struct SurfaceParams {
  SurfaceMethod method = SurfaceMethod::subvoxel;
  double skin_hu = -500.0;  // iso level of d_surf's surface
  double bone_hu = 200.0;   // iso level of d_bone's surface
  double band_mm = 0.0;     // sub-voxel band; 0 = twice the grid's coarsest spacing
  // d_surf's nodes within this distance move to the trilinear HU's own iso-surface
  // (prep/maps/iso_projection.hpp); < 0 = three coarsest spacings, 0 = off
  double skin_projection_mm = -1.0;
};

const char* surface_method_name(SurfaceMethod method);
// Throws UsageError unless `name` is "subvoxel" or "mask".
SurfaceMethod parse_surface_method(const std::string& name);

struct PrepParams {
  SegmentationParams segmentation;
  DistanceParams distance;
  SurfaceParams surface;
  // The bone levels (segmentation's bone_seed_hu, bone_grow_hu and the surface's bone_hu) follow
  // the scan's soft-tissue peak (prep/segment/hu_levels.hpp); false: used as given.
  bool adapt_bone_levels = true;
  // Contrast-filled lumens found in the scan (prep/vessel/vessel_segmentation.hpp), kept out of
  // the bone and written as vessel.nii.gz and d_vessel.nii.gz when the scan has any; false:
  // prep.json says contrast_phase "unknown" (docs/anatomy.md for what it finds and misses).
  bool find_vessels = true;
  VesselParams vessels;
  // A lab's label map of the CT (prep/labels/label_maps.hpp: TotalSegmentator's total output, a
  // 3D Slicer .seg.nrrd); empty = none. Its bone classes replace the bone palp segments from the
  // HU, its vessels the vessel search; each organ or muscle becomes <name>.nii.gz and
  // d_<name>.nii.gz. labels_map: the class map of a file that names no classes ("" or
  // kTotalSegmentatorMap, "totalsegmentator").
  std::string labels_path;
  std::string labels_map;
  // On a CT coarser than this (mm, any axis), the maps lie on its grid refined to at most this
  // spacing, nodes aligned (prep/maps/map_refine.hpp); 0 = the CT's own grid.
  double map_spacing_mm = kDefaultMapSpacingMm;
  bool use_cache = true;
  // Prep a volume that does not look like a CT in HU (prep/ct_check.hpp) instead of refusing it.
  // Not part of the cache key: it changes whether prep runs, never what it writes.
  bool not_hu_ok = false;
};

struct StageTiming {
  std::string name;
  double seconds = 0.0;
  std::size_t peak_rss_bytes = 0;  // the process's peak resident memory when the stage ended
  // CPU seconds of the whole process (every thread, a background write included) during the
  // stage: steadier than the wall clock on a shared machine. 0 for background writes.
  double cpu_seconds = 0.0;
};

// A structure prep wrote besides the body (bone, vessel, a labelled organ or muscle), for the
// summary: from prep.json's "structures".
struct PrepStructure {
  std::string name;  // "bone", "vessel", "liver", ...
  std::string kind;  // "bone", "vessel", "organ", "muscle"
  std::uint64_t voxels = 0;
  std::string source;  // "auto", or "labels FILE (its classes)"
};

struct PrepResult {
  std::string input;
  std::string out_dir;
  Grid grid;
  Grid map_grid;  // d_surf's and d_bone's: `grid`, or its aligned refinement (map_spacing_mm)
  SegmentationStats stats;
  std::vector<StageTiming> stages;  // in order; empty when served from the cache
  double total_seconds = 0.0;
  std::size_t peak_rss_bytes = 0;
  bool from_cache = false;
  std::string cache_key;
  std::string orientation;     // the input's patient orientation code ("LPS", "RAS", ...)
  double obliquity_deg = 0.0;  // of the input's direction matrix
  bool reoriented = false;     // resampled onto the nearest axis-aligned frame
  std::string hu_warning;      // what the CT check found when not_hu_ok let it through
  HuLevels hu_levels;          // what the scan's histogram gave (used when adapt_bone_levels)
  std::string contrast_phase = "unknown";  // spec "Files": none, arterial, portal-venous, ...
  std::uint64_t vessel_voxels = 0;         // vessel.nii.gz's, when written
  std::vector<PrepStructure> structures;   // bone, vessel when written, then the rest by name
};

// Progress reports: a stage starting ("reading CT", ...) or finishing (with its seconds).
using PrepProgress = std::function<void(const std::string& stage, bool finished, double seconds)>;

// Runs the pipeline; throws palp::Error subclasses on bad input or I/O failure. Creates out_dir.
// With labels_path, the label map is read onto the CT's grid before anything is written (a map
// refused: its one-line InputError, nothing written).
// Before segmenting: an input that does not look like a CT in HU is refused (InputError, unless
// not_hu_ok), and an oblique one is resampled onto the nearest axis-aligned frame
// (prep/reorient.hpp), the maps then lying on that grid.
PrepResult run_prep(const std::string& input, const std::string& out_dir, const PrepParams& params,
                    const PrepProgress& progress = {});

// The cache key of an input under given parameters (hex): hashes the input's bytes (every file
// of a DICOM directory, in name order), or the phantom's name, the label map's bytes (every file
// of a folder, in name order) and every parameter. InputError when the label map is missing.
std::string prep_cache_key(const std::string& input, const PrepParams& params);
// What prep_cache_key refuses (a missing input, a FIFO, a symlink loop, a missing label map),
// refused the same way, without reading the files.
void check_prep_inputs(const std::string& input, const PrepParams& params);

// File names inside a prep directory.
inline constexpr const char* kBodyFile = "body.nii.gz";
inline constexpr const char* kBoneFile = "bone.nii.gz";
inline constexpr const char* kSurfaceDistanceFile = "d_surf.nii.gz";
inline constexpr const char* kBoneDistanceFile = "d_bone.nii.gz";
inline constexpr const char* kPrepJsonFile = "prep.json";
// Structures beyond bone, when the scan shows them (spec "Files").
inline constexpr const char* kVesselFile = "vessel.nii.gz";
inline constexpr const char* kVesselDistanceFile = "d_vessel.nii.gz";
// With --labels naming vertebrae, the sacrum or ribs: each labelled one its own value (uint8 on
// the CT's grid), named by prep.json's "skeleton_labels": {"file", "source", "labels": {"1":
// "vertebrae_L5", ..., "7": "rib_right_9", ...}} (labels::skeleton_name's names).
inline constexpr const char* kSkeletonLabelsFile = "skeleton_labels.nii.gz";
// The CT itself (int16 HU, after reorientation: on the masks' grid, which the maps' is or refines),
// for palpd's render volume.
inline constexpr const char* kCtFile = "ct.nii.gz";

}  // namespace palp
