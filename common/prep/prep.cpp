// Preprocessing pipeline (see prep.hpp). Stages and their data flow:
//   read CT      input file / DICOM dir / phantom -> CtVolume (HU)
//   read labels  a lab's label map (--labels) -> bone, vessel, organs' boxes on the CT's grid
//   body mask    CT -> body (patient only, internal air filled)
//   then two threads at once:
//     surf_job   skin points (CT + body -> iso-surface points on the mask's edges, subvoxel
//                only), d_surf (body + skin points -> signed distance map, projected onto the
//                HU iso-surface), write d_surf; the job holds the CT until its projection is done
//     this one   HU levels, vessels (CT + body + levels -> contrast-filled lumens, contrast
//                phase), bone mask (CT + body - lumens -> bone), bone points (subvoxel only),
//                then waits for surf_job
//   d_bone       bone (+ bone points) -> signed distance map, in d_surf's buffer; write d_bone
//   d_vessel     lumens -> signed distance map to the mask's faces, same buffer (when any)
//   structures   the labelled arteries and each labelled organ / muscle, or a phantom's own
//                truth (artery, liver) -> <name>.nii.gz, d_<name>.nii.gz, one at a time
//                (prep_structures.hpp); labelled bone replaces the bone mask, labelled vessels
//                the vessel search
//   prep.json    grid, parameters, counts, timings, CPU seconds, peak memory, cache key
// The CT copy and the masks are written on a background thread (background_writes.hpp) from the
// moment each is final; they are waited for before d_bone. Bone segmentation runs mostly on one
// core, so d_surf on the other costs little wall time.
#include "prep/prep.hpp"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <system_error>

#include "base/errors.hpp"
#include "base/file_replace.hpp"
#include "base/parallel.hpp"
#include "base/patient_frame.hpp"
#include "io/ct_io.hpp"
#include "io/gzip.hpp"
#include "prep/background_writes.hpp"
#include "prep/ct_check.hpp"
#include "prep/labels/label_maps.hpp"
#include "prep/maps/distance_transform.hpp"
#include "prep/maps/iso_projection.hpp"
#include "prep/maps/map_refine.hpp"
#include "prep/maps/subvoxel_distance.hpp"
#include "prep/output_guard.hpp"
#include "prep/prep_cache.hpp"
#include "prep/prep_structures.hpp"
#include "prep/reorient.hpp"
#include "prep/segment/components.hpp"
#include "prep/vessel/vessel_segmentation.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

nlohmann::json grid_json(const Grid& grid) {
  return {{"dimensions", grid.dims},
          {"spacing_mm", grid.spacing},
          {"origin_lps_mm", grid.world.origin},
          {"direction_lps", grid.world.direction}};
}

// The sub-voxel band on this grid: the parameter, or twice the coarsest spacing.
double subvoxel_band_mm(const SurfaceParams& surface, const Grid& grid) {
  if (surface.band_mm > 0.0) return surface.band_mm;
  return 2.0 * grid.max_spacing();
}

// The reach of d_surf's projection onto the HU iso-surface: the parameter, or three coarsest
// spacings (a pad 6 mm deep on a 3 mm CT reads nodes up to 9 mm deep).
double skin_projection_mm(const SurfaceParams& surface, const Grid& grid) {
  if (surface.skin_projection_mm >= 0.0) return surface.skin_projection_mm;
  return 3.0 * grid.max_spacing();
}

// The same for a copy of the file `from` (a new file, so the umask's permissions, not the
// input's: a read-only input gives a scene that can be prepped again over).
void copy_atomically(const fs::path& from, const fs::path& path) {
  const fs::path partial = path.string() + ".partial.nii.gz";
  {
    std::ifstream in(from, std::ios::binary);
    std::ofstream out(partial, std::ios::binary | std::ios::trunc);
    if (!in || !out || !(out << in.rdbuf()) || !out.flush())
      throw Error(path.string() + ": cannot be written from " + from.string());
  }
  std::error_code ec;
  fs::rename(partial, path, ec);
  if (ec) throw Error(path.string() + ": cannot be written: " + ec.message());
}

// Whether the scene's copy of the CT can be the input file itself: a gzip'd NIfTI that prep uses
// as read (not reoriented). Read again it gives the same voxels and grid, and its voxels are not
// deflated a second time (at 512x512x400, 0.6 s of CPU).
bool input_serves_as_ct_copy(const std::string& input, bool reoriented) {
  return !reoriented && is_nifti_name(input) && file_is_gzip(input);
}

// CPU seconds of the whole process so far (all threads).
double process_cpu_seconds() {
  timespec t{};
  if (clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t) != 0) return 0.0;
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

using segmentation::count_nonzero;

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
nlohmann::json vessel_json(const VesselResult& v) {
  return {{"kind", "vessel"},
          {"source", "auto"},
          {"method", "contrast-filled lumens (prep/vessel/vessel_segmentation.hpp)"},
          {"files", {kVesselFile, kVesselDistanceFile}},
          {"voxels", v.voxels},
          {"lumens", v.lumens},
          {"lumen_level_hu", v.lumen_level_hu},
          {"rejected_enclosed_by_cortex", v.rejected_shell},
          {"rejected_not_uniform", v.rejected_spread},
          {"rejected_brighter_at_surface", v.rejected_surface},
          {"rejected_joined_to_no_trunk", v.rejected_thin}};
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
nlohmann::json prep_json(const PrepResult& result, const PrepParams& params,
                         const SegmentationParams& segmentation, const SurfaceParams& surface,
                         const MapRecord& maps, const fs::path& dir) {
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
  {
    const HuLevels& h = result.hu_levels;
    json["hu_levels"] = {
        {"mode", params.adapt_bone_levels ? "adapted to the scan" : "as given"},
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

// Writes `json` to `path` through a .partial file renamed over it.
void write_json_atomically(const fs::path& path, const nlohmann::json& json) {
  replace_file(path.string(), json.dump(2) + '\n');
}

}  // namespace

const char* surface_method_name(SurfaceMethod method) {
  return method == SurfaceMethod::mask ? "mask" : "subvoxel";
}

SurfaceMethod parse_surface_method(const std::string& name) {
  if (name == "subvoxel") return SurfaceMethod::subvoxel;
  if (name == "mask") return SurfaceMethod::mask;
  throw UsageError("--surface must be subvoxel or mask, not '" + name + "'");
}

PrepResult run_prep(const std::string& input, const std::string& out_dir, const PrepParams& params,
                    const PrepProgress& progress) {
  check_distance_band(params.distance.band_mm);  // before anything is read or written
  const auto start = Clock::now();
  PrepResult result;
  result.input = input;
  result.out_dir = out_dir;
  const fs::path dir(out_dir);
  // A failed or interrupted run leaves no temporary file, and no output at all in a directory
  // it created (which is removed).
  PrepOutputGuard guard(
      dir, {kBodyFile, kBoneFile, kSurfaceDistanceFile, kBoneDistanceFile, kCtFile, kPrepJsonFile,
            kVesselFile, kVesselDistanceFile, kSkeletonLabelsFile});
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    throw Error(out_dir + ": cannot create output directory" + (ec ? ": " + ec.message() : ""));
  }

  result.cache_key = prep_cache_key(input, params);
  nlohmann::json cached;
  if (params.use_cache && cache_is_valid(dir, result.cache_key, &cached)) {
    read_cached_result(cached, result);
    result.total_seconds = std::chrono::duration<double>(Clock::now() - start).count();
    result.peak_rss_bytes = peak_rss_bytes();
    guard.commit();
    return result;
  }
  // The files an earlier prep recorded, removed once this run's inputs are accepted (below).
  const std::vector<std::string> previous = recorded_outputs(dir);
  // Remove a previous prep.json first: until the new one is written the directory is not a
  // valid cache, whatever happens in between.
  fs::remove(dir / kPrepJsonFile, ec);
  // Structures an earlier run found and this one may not.
  for (const char* name : {kVesselFile, kVesselDistanceFile, kSkeletonLabelsFile})
    fs::remove(dir / name, ec);

  auto stage = [&](const std::string& name, auto&& work) {
    if (progress) progress(name, false, 0.0);
    const auto t0 = Clock::now();
    const double cpu0 = process_cpu_seconds();
    work();
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    result.stages.push_back({name, seconds, peak_rss_bytes(), process_cpu_seconds() - cpu0});
    if (progress) progress(name, true, seconds);
  };

  // The CT and the masks are shared with the background writer, which frees them once written.
  auto ct_owner = std::make_shared<CtVolume>();
  auto body_owner = std::make_shared<Mask>();
  auto bone_owner = std::make_shared<Mask>();
  CtVolume& ct = *ct_owner;
  const Mask& body = *body_owner;
  const Mask& bone = *bone_owner;
  BackgroundWrites writes;
  // Queues the write of a volume the pipeline no longer changes.
  auto write_in_background = [&](const char* name, const char* file, auto owner) {
    writes.add(
        name,
        [owner = std::shared_ptr<const typename decltype(owner)::element_type>(std::move(owner)),
         path = dir / file] { write_atomically(path, *owner); });
  };
  // Reports the background writes finished so far as stages of their own.
  auto report_background = [&](const std::vector<BackgroundWrites::Done>& done) {
    for (const auto& d : done) {
      if (progress) progress(d.name, false, 0.0);
      result.stages.push_back({d.name, d.seconds, peak_rss_bytes()});
      if (progress) progress(d.name, true, d.seconds);
    }
  };
  // Structures beyond bone and vessels, written last, one at a time: a label map's arteries,
  // organs and muscles, or the truth of a phantom that draws its own (prep_structures.hpp).
  std::vector<LabelledStructure> structures;
  stage("read CT", [&] {
    ct = read_ct_with_truth(input, params.labels_path.empty() ? &structures : nullptr);
  });
  stage("check CT", [&] {
    const CtCheck check = check_hu(ct);
    if (!check.plausible && !params.not_hu_ok) throw InputError(not_a_ct_message(input, check));
    if (!check.plausible) result.hu_warning = check.finding;
  });
  const PatientFrame frame = patient_frame(ct.grid);
  result.orientation = frame.orientation_code();
  result.obliquity_deg = frame.obliquity_deg();
  if (result.obliquity_deg > kAxisAlignedToleranceDeg) {
    stage("reorient", [&] { ct = resample_axis_aligned(ct); });
    result.reoriented = true;
  }
  result.grid = ct.grid;
  // A lab's label map, on the CT's grid, before anything is written (a refused one leaves nothing).
  LabelMaps labels;
  if (!params.labels_path.empty()) {
    stage("read labels",
          [&] { labels = read_label_maps(params.labels_path, ct.grid, {params.labels_map}); });
    if (auto artery = labelled_artery(labels)) structures.push_back(std::move(*artery));
    labels.vein = Mask{};  // the split's classes and voxels are in labels.source
    for (LabelledStructure& organ : labels.organs) structures.push_back(std::move(organ));
    labels.organs.clear();
  }
  guard.add_names(structure_files(structures));
  remove_stale_outputs(dir, previous, input, params.labels_path);
  if (input_serves_as_ct_copy(input, result.reoriented)) {
    writes.add("bg write CT",
               [from = fs::path(input), path = dir / kCtFile] { copy_atomically(from, path); });
  } else {
    write_in_background("bg write CT", kCtFile, ct_owner);
  }
  stage("body mask", [&] { *body_owner = segment_body(ct, params.segmentation, &result.stats); });
  write_in_background("bg write body", kBodyFile, body_owner);
  if (!params.not_hu_ok) {
    const std::string finding = check_body_fraction(count_nonzero(body), ct.grid);
    if (!finding.empty())
      throw InputError(
          input + ": does not look like a CT in Hounsfield units: " + finding +
          ". To prep it anyway: palp prep --not-hu-ok INPUT --out DIR (then use DIR as the "
          "scene)");
  }
  // d_surf needs only the CT, the body mask and the skin level: it is computed and written on a
  // thread of its own (`surf_job`) while this one segments the bone (mostly one core), then its
  // buffer serves d_bone.
  const bool subvoxel = params.surface.method == SurfaceMethod::subvoxel;
  const double band = subvoxel_band_mm(params.surface, ct.grid);
  const double projection = skin_projection_mm(params.surface, ct.grid);
  DistanceMap map;
  SurfacePoints skin_points, bone_points;
  std::size_t skin_count[2] = {0, 0};  // the skin's points, and how many the HU placed
  MapRecord record;                    // what prep.json says of the maps
  record.band_mm = band;
  record.projection_mm = projection;
  if (!labels.skeleton.data.empty()) {  // the labelled vertebrae and ribs, each its own value
    nlohmann::json names = nlohmann::json::object();
    for (std::size_t v = 0; v < labels.skeleton_names.size(); ++v)
      names[std::to_string(v + 1)] = labels.skeleton_names[v];
    record.skeleton = {
        {"file", kSkeletonLabelsFile}, {"source", params.labels_path}, {"labels", names}};
    write_in_background("bg write skeleton labels", kSkeletonLabelsFile,
                        std::make_shared<Mask>(std::move(labels.skeleton)));
  }
  // The maps' grid: the CT's, or its aligned refinement (--map-spacing; prep/maps/map_refine.hpp).
  const Refinement& refine = record.refine = map_refinement(result.grid, params.map_spacing_mm);
  result.map_grid = refined_grid(result.grid, refine);
  // The map of `mask` into `map` on the CT's grid, upsampled to the maps' grid when refined, then
  // (the skin's, when `hu`) projected onto the HU iso-surface at the maps' nodes.
  auto compute_map = [&](const Mask& mask, const SurfacePoints& points, const CtVolume* hu) {
    if (subvoxel) {
      subvoxel_signed_distance(points, mask, band, params.distance.band_mm, map,
                               params.distance.threads);
    } else {
      signed_distance(mask, params.distance, map);
    }
    if (is_refined(refine)) map = upsample_aligned(map, refine, params.distance.threads);
    if (subvoxel && hu != nullptr)
      record.projected = project_skin_map(*hu, mask, params.surface.skin_hu, projection,
                                          params.distance.band_mm, map, params.distance.threads);
  };
  // The HU are needed by d_surf past the bone's points only for its projection onto their
  // iso-surface; the job drops them after it. Nobody changes them: the writers read them.
  std::shared_ptr<const CtVolume> surf_ct = ct_owner;
  BackgroundWrites surf_job;  // after everything its jobs use, so it ends before they do
  if (subvoxel) {
    surf_job.add("skin points", [&] {
      skin_points = surface_points(*surf_ct, body, params.surface.skin_hu, params.distance.threads);
      skin_count[0] = skin_points.points.size();
      skin_count[1] = skin_points.interpolated;
    });
  }
  surf_job.add("d_surf", [&] {
    compute_map(body, skin_points, subvoxel && projection != 0.0 ? surf_ct.get() : nullptr);
    surf_ct.reset();
    skin_points = SurfacePoints{};
    value_range(map, record.surf_range, params.distance.threads);
  });
  surf_job.add("write d_surf", [&] {
    write_atomically(dir / kSurfaceDistanceFile, map, record.surf_range[0], record.surf_range[1]);
  });

  // The bone levels, shifted with the scan's soft-tissue peak unless given
  // (prep/segment/hu_levels.hpp).
  SegmentationParams segmentation = params.segmentation;
  SurfaceParams surface = params.surface;
  stage("HU levels", [&] {
    result.hu_levels = estimate_hu_levels(
        ct, body, {segmentation.bone_seed_hu, segmentation.bone_grow_hu, surface.bone_hu});
    if (params.adapt_bone_levels) {
      segmentation.bone_seed_hu = result.hu_levels.levels.seed_hu;
      segmentation.bone_grow_hu = result.hu_levels.levels.grow_hu;
      surface.bone_hu = result.hu_levels.levels.iso_hu;
    }
  });
  // Contrast-filled lumens: not bone; their own mask and map when the scan has any.
  auto vessel_owner = std::make_shared<Mask>();
  if (!labels.vessel.data.empty()) {  // labelled vessels replace the search
    result.vessel_voxels = count_nonzero(labels.vessel);
    record.structures["vessel"] = labelled_vessel_json(labels, result.vessel_voxels);
    *vessel_owner = std::move(labels.vessel);
  } else if (params.find_vessels) {
    stage("vessels", [&] {
      const HuLevels& h = result.hu_levels;
      const double soft = h.peak_found ? h.soft_peak_hu : kNominalSoftTissueHu + h.offset_hu;
      VesselResult v = segment_vessels(ct, body, soft, segmentation.bone_seed_hu, params.vessels);
      result.contrast_phase = v.contrast_phase;
      result.vessel_voxels = v.voxels;
      if (v.voxels > 0) record.structures["vessel"] = vessel_json(v);
      *vessel_owner = std::move(v.lumen);
    });
  }
  const bool has_vessels = result.vessel_voxels > 0;
  if (has_vessels) write_in_background("bg write vessel", kVesselFile, vessel_owner);
  const bool labelled_bone = !labels.bone.data.empty();
  if (labelled_bone) {  // the union of the label map's bone classes, as it is
    *bone_owner = std::move(labels.bone);
  } else {
    stage("bone mask", [&] {
      *bone_owner = segment_bone(ct, body, segmentation, &result.stats,
                                 has_vessels ? vessel_owner.get() : nullptr);
    });
  }
  write_in_background("bg write bone", kBoneFile, bone_owner);
  if (subvoxel) {
    stage("bone points", [&] {
      bone_points = surface_points(ct, bone, surface.bone_hu, params.distance.threads);
    });
  }
  ct_owner.reset();
  result.stats.body_voxels = count_nonzero(body);
  result.stats.bone_voxels = count_nonzero(bone);
  record.structures["bone"] = labelled_bone ? labelled_bone_json(labels, result.stats.bone_voxels)
                                            : auto_structure_json("bone", result.stats.bone_voxels,
                                                                  {kBoneFile, kBoneDistanceFile});
  std::vector<BackgroundWrites::Done> written;
  stage("wait d_surf", [&] { written = surf_job.wait(); });
  report_background(written);
  if (subvoxel) {
    record.point_counts = {{"skin", {skin_count[0], skin_count[1]}},
                           {"bone", {bone_points.points.size(), bone_points.interpolated}}};
  }
  // The CT's copy and the masks are out by now (they usually are long before).
  stage("wait CT+masks", [&] { written = writes.wait(); });
  report_background(written);

  stage("d_bone", [&] { compute_map(bone, bone_points, nullptr); });
  bone_points = SurfacePoints{};
  value_range(map, record.bone_range, params.distance.threads);
  stage("write d_bone", [&] {
    write_atomically(dir / kBoneDistanceFile, map, record.bone_range[0], record.bone_range[1]);
  });
  if (has_vessels) {
    stage("d_vessel", [&] {
      signed_distance(*vessel_owner, params.distance, map);
      if (is_refined(refine)) map = upsample_aligned(map, refine, params.distance.threads);
      value_range(map, record.vessel_range, params.distance.threads);
    });
    vessel_owner.reset();
    stage("write d_vessel", [&] {
      write_atomically(dir / kVesselDistanceFile, map, record.vessel_range[0],
                       record.vessel_range[1]);
    });
  }
  if (!structures.empty()) {  // one at a time: a CT-sized mask and the maps' buffer
    stage("structures", [&] {
      write_labelled_structures(structures, result.grid, params.distance, refine, dir, map,
                                record.structures, record.structure_files);
    });
  }
  result.structures = structure_summaries(record.structures);

  result.total_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  result.peak_rss_bytes = peak_rss_bytes();

  write_json_atomically(dir / kPrepJsonFile,
                        prep_json(result, params, segmentation, surface, record, dir));
  guard.commit();
  return result;
}

}  // namespace palp
