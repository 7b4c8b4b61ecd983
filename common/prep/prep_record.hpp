// prep.json, the record a prep directory carries (prep.hpp): what prep.cpp's run writes into it
// and what a cached run reads back from it.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "prep/maps/iso_projection.hpp"
#include "prep/maps/map_refine.hpp"
#include "prep/prep.hpp"
#include "prep/vessel/vessel_segmentation.hpp"

namespace palp {

// What prep.json says of the maps besides the result: the surface method's facts and the maps'
// value ranges (also the .nii.gz headers' cal_min/cal_max).
struct MapRecord {
  Refinement refine{1, 1, 1};  // the maps' grid refines the CT's by these factors
  double band_mm = 0.0;        // subvoxel: the near band
  double projection_mm = 0.0;  // subvoxel: the skin projection's reach
  IsoProjectionStats projected;
  nlohmann::json point_counts;  // per surface: points, and how many the HU placed (not midpoints)
  float surf_range[2] = {0, 0}, bone_range[2] = {0, 0}, vessel_range[2] = {0, 0};
  nlohmann::json structures = nlohmann::json::object();  // per structure: its source, voxels
  std::vector<std::string> structure_files;              // a label map's organs' and muscles' files
  nlohmann::json skeleton;  // the skeleton's labels' name table (prep.hpp), null without
};

// prep.json's record of the lumens found in the scan.
nlohmann::json vessel_json(const VesselResult& v);

// A cached prep directory's prep.json -> the grids and voxel counts of `result`.
void read_cached_result(const nlohmann::json& cached, PrepResult& result);

// prep.json: the grids, parameters and levels used, counts, timings, CPU seconds, peak memory,
// the outputs' sizes in `dir`, and the cache key.
nlohmann::json prep_record_json(const PrepResult& result, const PrepParams& params,
                                const SegmentationParams& segmentation,
                                const SurfaceParams& surface, const MapRecord& maps,
                                const std::filesystem::path& dir);

// CPU seconds of the whole process so far (all threads).
double process_cpu_seconds();

}  // namespace palp
