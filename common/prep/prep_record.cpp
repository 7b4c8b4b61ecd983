// prep.json (prep_record.hpp): composed from a run's result, read back from a cached one.
#include "prep/prep_record.hpp"

#include <ctime>

#include "base/parallel.hpp"
#include "base/patient_frame.hpp"
#include "prep/prep_cache.hpp"
#include "prep/prep_structures.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;

nlohmann::json grid_json(const Grid& grid) {
  return {{"dimensions", grid.dims},
          {"spacing_mm", grid.spacing},
          {"origin_lps_mm", grid.world.origin},
          {"direction_lps", grid.world.direction}};
}

// prep.json's "hu_levels": the scan's peaks and the bone levels used.
nlohmann::json hu_levels_json(const HuLevels& h, const PrepParams& params,
                              const SegmentationParams& segmentation,
                              const SurfaceParams& surface) {
  return {{"mode", params.adapt_bone_levels ? "adapted to the scan" : "as given"},
          {"soft_tissue_peak_hu", h.peak_found ? nlohmann::json(h.soft_peak_hu) : nlohmann::json()},
          {"soft_tissue_share", h.peak_share},
          {"fat_peak_hu", h.fat_found ? nlohmann::json(h.fat_peak_hu) : nlohmann::json()},
          {"fat_share", h.fat_share},
          {"offset_hu", params.adapt_bone_levels ? h.offset_hu : 0.0},
          {"note", h.note},
          {"bone_seed_hu", segmentation.bone_seed_hu},
          {"bone_grow_hu", segmentation.bone_grow_hu},
          {"bone_iso_hu", surface.bone_hu}};
}

}  // namespace

// CPU seconds of the whole process so far (all threads).
double process_cpu_seconds() {
  timespec t{};
  if (clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t) != 0) return 0.0;
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// prep.json's record of the lumens found in the scan.
nlohmann::json vessel_json(const VesselResult& v) {
  return {{"kind", "vessel"},
          {"source", "auto"},
          {"method", "contrast-filled lumens (prep/vessel/vessel_segmentation.hpp)"},
          {"files", {kVesselFile, kVesselDistanceFile}},
          {"voxels", v.voxels},
          {"lumens", v.lumens},
          {"lumen_level_hu", v.lumen_level_hu},
          {"second_trunk_level_hu", v.second_trunk_level_hu},
          {"tube_level_hu", v.tube_level_hu},
          {"rejected_enclosed_by_cortex", v.rejected_shell},
          {"rejected_not_uniform", v.rejected_spread},
          {"rejected_brighter_at_surface", v.rejected_surface},
          {"rejected_joined_to_no_trunk", v.rejected_thin},
          {"rejected_enhancing_organ", v.rejected_organ}};
}

// A cached prep directory's prep.json -> the grids and voxel counts of `result`.
void read_cached_result(const nlohmann::json& cached, PrepResult& result) {
  result.from_cache = true;
  result.grid.dims = cached["grid"]["dimensions"].get<Index3>();
  result.grid.spacing = cached["grid"]["spacing_mm"].get<Vec3>();
  result.map_grid = result.grid;
  if (cached.contains("map_grid")) {
    result.map_grid.dims = cached["map_grid"]["dimensions"].get<Index3>();
    result.map_grid.spacing = cached["map_grid"]["spacing_mm"].get<Vec3>();
  }
  result.stats.body_voxels = cached["voxels"]["body"].get<std::uint64_t>();
  result.stats.bone_voxels = cached["voxels"]["bone"].get<std::uint64_t>();
  result.vessel_voxels = cached["voxels"].value("vessel", std::uint64_t{0});
  result.structures = structure_summaries(cached.value("structures", nlohmann::json()));
}

// prep.json: the grids, parameters and levels used, counts, timings, CPU seconds, peak memory,
// the outputs' sizes in `dir`, and the cache key.
nlohmann::json prep_record_json(const PrepResult& result, const PrepParams& params,
                                const SegmentationParams& segmentation,
                                const SurfaceParams& surface, const MapRecord& maps,
                                const fs::path& dir) {
  nlohmann::json json;
  json["palp_prep_version"] = kPrepAlgorithmVersion;
  json["input"] = result.input;
  json["cache_key"] = result.cache_key;
  json["grid"] = grid_json(result.grid);
  json["map_grid"] = grid_json(result.map_grid);  // d_surf, d_bone: the grid refined by
  json["map_refinement"] = maps.refine;           // these factors (prep/maps/map_refine.hpp)
  json["patient"] = {{"input_orientation", result.orientation},
                     {"input_obliquity_deg", result.obliquity_deg},
                     {"reoriented", result.reoriented},
                     {"orientation", patient_frame(result.grid).orientation_code()}};
  if (!result.hu_warning.empty()) json["not_hu_ok"] = result.hu_warning;
  json["parameters"] = params_json(params);
  json["surface"] = surface_method_name(params.surface.method);
  json["hu_levels"] = hu_levels_json(result.hu_levels, params, segmentation, surface);
  if (params.surface.method == SurfaceMethod::subvoxel) {
    json["surface_iso_hu"] = {{"skin", params.surface.skin_hu}, {"bone", surface.bone_hu}};
    json["subvoxel_band_mm_used"] = maps.band_mm;
    json["skin_projection"] = {{"reach_mm", maps.projection_mm},
                               {"nodes", {maps.projected.visited, maps.projected.projected}}};
    // [points, placed by HU]: the rest straddle no level (the mask cut there: table contact,
    // filled lungs, marrow) and sit at edge midpoints, as the mask's faces would.
    json["surface_points"] = maps.point_counts;
  }
  json["contrast_phase"] = result.contrast_phase;
  json["structures"] = maps.structures;
  if (!maps.skeleton.is_null()) json["skeleton_labels"] = maps.skeleton;
  json["voxels"] = {{"total", result.grid.voxel_count()},
                    {"body", result.stats.body_voxels},
                    {"bone", result.stats.bone_voxels},
                    {"vessel", result.vessel_voxels},
                    {"removed_non_patient", result.stats.removed_non_patient_voxels},
                    {"table", result.stats.table_voxels}};
  json["distance_range_mm"] = {{"d_surf", {maps.surf_range[0], maps.surf_range[1]}},
                               {"d_bone", {maps.bone_range[0], maps.bone_range[1]}}};
  if (result.vessel_voxels > 0)
    json["distance_range_mm"]["d_vessel"] = {maps.vessel_range[0], maps.vessel_range[1]};
  nlohmann::json timings = nlohmann::json::object();
  for (const auto& s : result.stages) timings[s.name] = s.seconds;
  timings["total"] = result.total_seconds;
  json["timings_s"] = timings;
  nlohmann::json cpu = nlohmann::json::object();
  for (const auto& s : result.stages)
    if (s.cpu_seconds > 0.0) cpu[s.name] = s.cpu_seconds;
  cpu["total"] = process_cpu_seconds();
  json["cpu_seconds"] = cpu;
  json["peak_memory_bytes"] = result.peak_rss_bytes;
  nlohmann::json stage_peaks = nlohmann::json::object();
  for (const auto& s : result.stages) stage_peaks[s.name] = s.peak_rss_bytes;
  json["peak_memory_bytes_after_stage"] = stage_peaks;
  json["threads"] = thread_count_or_default(params.distance.threads);
  nlohmann::json sizes = nlohmann::json::object();
  for (const char* name :
       {kBodyFile, kBoneFile, kSurfaceDistanceFile, kBoneDistanceFile, kCtFile}) {
    sizes[name] = fs::file_size(dir / name);
  }
  if (result.vessel_voxels > 0) {
    for (const char* name : {kVesselFile, kVesselDistanceFile})
      sizes[name] = fs::file_size(dir / name);
  }
  for (const std::string& name : maps.structure_files) sizes[name] = fs::file_size(dir / name);
  if (!maps.skeleton.is_null())
    sizes[kSkeletonLabelsFile] = fs::file_size(dir / kSkeletonLabelsFile);
  json["file_bytes"] = sizes;
  return json;
}

}  // namespace palp
