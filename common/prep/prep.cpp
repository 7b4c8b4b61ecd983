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
// run_prep at the end of this file reads as this chain, each stage a step of one PrepRun; what
// prep.json records (and how a cached one is read back) is prep_record.*.
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
#include "prep/prep_record.hpp"
#include "prep/prep_structures.hpp"
#include "prep/reorient.hpp"
#include "prep/segment/components.hpp"
#include "prep/vessel/vessel_segmentation.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

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

using segmentation::count_nonzero;

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

namespace {

// One run of the pipeline, its stages in the order run_prep calls them. The members are declared
// in the order the stages need them: what a background job uses is declared before the job's
// BackgroundWrites, so a failed run stops the job before its data goes.
class PrepRun {
 public:
  PrepRun(const std::string& input, const std::string& out_dir, const PrepParams& params,
          const PrepProgress& progress)
      : input_(input),
        params_(params),
        progress_(progress),
        dir_(out_dir),
        // A failed or interrupted run leaves no temporary file, and no output at all in a
        // directory it created (which is removed).
        guard_(dir_, {kBodyFile, kBoneFile, kSurfaceDistanceFile, kBoneDistanceFile, kCtFile,
                      kPrepJsonFile, kVesselFile, kVesselDistanceFile, kSkeletonLabelsFile}) {
    result_.input = input;
    result_.out_dir = out_dir;
  }

  void create_directory();
  bool served_from_cache();
  void key_inputs();
  void forget_previous_run();
  void read_input();
  void read_labels();
  void body_mask();
  void start_surface_job();
  void hu_levels();
  void vessels();
  void bone_mask();
  void wait_surface_and_writes();
  void bone_map();
  void vessel_map();
  void structure_maps();
  PrepResult finish();
  PrepResult take_result() { return std::move(result_); }

 private:
  // A named stage: timed, its CPU seconds and the peak memory after it recorded, reported.
  template <class Work>
  void stage(const std::string& name, Work&& work) {
    if (progress_) progress_(name, false, 0.0);
    const auto t0 = Clock::now();
    const double cpu0 = process_cpu_seconds();
    work();
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    result_.stages.push_back({name, seconds, peak_rss_bytes(), process_cpu_seconds() - cpu0});
    if (progress_) progress_(name, true, seconds);
  }
  // Queues the write of a volume the pipeline no longer changes.
  template <class Volume>
  void write_in_background(const char* name, const char* file, std::shared_ptr<Volume> owner) {
    writes_.add(name, [owner = std::shared_ptr<const Volume>(std::move(owner)),
                       path = dir_ / file] { write_atomically(path, *owner); });
  }
  // Reports the background writes finished so far as stages of their own.
  void report_background(const std::vector<BackgroundWrites::Done>& done) {
    for (const auto& d : done) {
      if (progress_) progress_(d.name, false, 0.0);
      result_.stages.push_back({d.name, d.seconds, peak_rss_bytes()});
      if (progress_) progress_(d.name, true, d.seconds);
    }
  }
  void write_ct_copy();
  void record_skeleton();
  void compute_map(const Mask& mask, const SurfacePoints& points, const CtVolume* hu);

  const std::string& input_;
  const PrepParams& params_;
  const PrepProgress& progress_;
  const Clock::time_point start_ = Clock::now();
  PrepResult result_;
  const fs::path dir_;
  PrepOutputGuard guard_;
  // The files an earlier prep recorded, removed once this run's inputs are accepted.
  std::vector<std::string> previous_;
  // The CT and the masks are shared with the background writer, which frees them once written.
  std::shared_ptr<CtVolume> ct_owner_ = std::make_shared<CtVolume>();
  std::shared_ptr<Mask> body_owner_ = std::make_shared<Mask>();
  std::shared_ptr<Mask> bone_owner_ = std::make_shared<Mask>();
  const Mask& body_ = *body_owner_;
  const Mask& bone_ = *bone_owner_;
  BackgroundWrites writes_;
  // Structures beyond bone and vessels, written last, one at a time: a label map's arteries,
  // organs and muscles, or the truth of a phantom that draws its own (prep_structures.hpp).
  std::vector<LabelledStructure> structures_;
  LabelMaps labels_;
  bool subvoxel_ = false;
  double band_ = 0.0, projection_ = 0.0;
  DistanceMap map_;
  SurfacePoints skin_points_, bone_points_;
  std::size_t skin_count_[2] = {0, 0};  // the skin's points, and how many the HU placed
  MapRecord record_;                    // what prep.json says of the maps
  // The HU are needed by d_surf past the bone's points only for its projection onto their
  // iso-surface; the job drops them after it. Nobody changes them: the writers read them.
  std::shared_ptr<const CtVolume> surf_ct_;
  BackgroundWrites surf_job_;  // after everything its jobs use, so it ends before they do
  // The bone levels, shifted with the scan's soft-tissue peak unless given.
  SegmentationParams segmentation_ = params_.segmentation;
  SurfaceParams surface_ = params_.surface;
  // Contrast-filled lumens: not bone; their own mask and map when the scan has any.
  std::shared_ptr<Mask> vessel_owner_ = std::make_shared<Mask>();
  bool has_vessels_ = false;
  bool labelled_bone_ = false;
};

void PrepRun::create_directory() {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_)) {
    throw Error(dir_.string() + ": cannot create output directory" +
                (ec ? ": " + ec.message() : ""));
  }
}

// A valid cache in the directory: its prep.json gives the result, nothing is computed. Without a
// prep.json there the key (a hash of every byte of the input) waits until the input has been read
// and checked (key_inputs): an input the readers refuse, a 1 GiB file of zeros named .dcm, is
// refused without being read whole first.
bool PrepRun::served_from_cache() {
  std::error_code ec;
  if (!params_.use_cache || !fs::exists(dir_ / kPrepJsonFile, ec)) {
    check_prep_inputs(input_, params_);
    return false;
  }
  result_.cache_key = prep_cache_key(input_, params_);
  nlohmann::json cached;
  if (!cache_is_valid(dir_, result_.cache_key, &cached)) return false;
  read_cached_result(cached, result_);
  result_.total_seconds = std::chrono::duration<double>(Clock::now() - start_).count();
  result_.peak_rss_bytes = peak_rss_bytes();
  guard_.commit();
  return true;
}

// The cache key prep.json records, when served_from_cache did not need it.
void PrepRun::key_inputs() {
  if (result_.cache_key.empty()) result_.cache_key = prep_cache_key(input_, params_);
}

void PrepRun::forget_previous_run() {
  previous_ = recorded_outputs(dir_);
  // Remove a previous prep.json first: until the new one is written the directory is not a
  // valid cache, whatever happens in between.
  std::error_code ec;
  fs::remove(dir_ / kPrepJsonFile, ec);
  // Structures an earlier run found and this one may not.
  for (const char* name : {kVesselFile, kVesselDistanceFile, kSkeletonLabelsFile})
    fs::remove(dir_ / name, ec);
}

// The CT, checked to be in HU, on an axis-aligned grid.
void PrepRun::read_input() {
  CtVolume& ct = *ct_owner_;
  stage("read CT", [&] {
    ct = read_ct_with_truth(input_, params_.labels_path.empty() ? &structures_ : nullptr);
  });
  stage("check CT", [&] {
    const CtCheck check = check_hu(ct);
    if (!check.plausible && !params_.not_hu_ok) throw InputError(not_a_ct_message(input_, check));
    if (!check.plausible) result_.hu_warning = check.finding;
  });
  const PatientFrame frame = patient_frame(ct.grid);
  result_.orientation = frame.orientation_code();
  result_.obliquity_deg = frame.obliquity_deg();
  if (result_.obliquity_deg > kAxisAlignedToleranceDeg) {
    stage("reorient", [&] { ct = resample_axis_aligned(ct); });
    result_.reoriented = true;
  }
  result_.grid = ct.grid;
}

// A lab's label map, on the CT's grid, before anything is written (a refused one leaves
// nothing); then the outputs of an earlier run this one will not write go, and the CT's copy
// starts.
void PrepRun::read_labels() {
  if (!params_.labels_path.empty()) {
    stage("read labels", [&] {
      labels_ = read_label_maps(params_.labels_path, ct_owner_->grid, {params_.labels_map});
    });
    if (auto artery = labelled_artery(labels_)) structures_.push_back(std::move(*artery));
    labels_.vein = Mask{};  // the split's classes and voxels are in labels.source
    for (LabelledStructure& organ : labels_.organs) structures_.push_back(std::move(organ));
    labels_.organs.clear();
  }
  guard_.add_names(structure_files(structures_));
  remove_stale_outputs(dir_, previous_, input_, params_.labels_path);
  write_ct_copy();
}

void PrepRun::write_ct_copy() {
  if (input_serves_as_ct_copy(input_, result_.reoriented)) {
    writes_.add("bg write CT",
                [from = fs::path(input_), path = dir_ / kCtFile] { copy_atomically(from, path); });
  } else {
    write_in_background("bg write CT", kCtFile, ct_owner_);
  }
}

void PrepRun::body_mask() {
  const CtVolume& ct = *ct_owner_;
  stage("body mask",
        [&] { *body_owner_ = segment_body(ct, params_.segmentation, &result_.stats); });
  write_in_background("bg write body", kBodyFile, body_owner_);
  if (!params_.not_hu_ok) {
    const std::string finding = check_body_fraction(count_nonzero(body_), ct.grid);
    if (!finding.empty())
      throw InputError(
          input_ + ": does not look like a CT in Hounsfield units: " + finding +
          ". To prep it anyway: palp prep --not-hu-ok INPUT --out DIR (then use DIR as the "
          "scene)");
  }
}

// The labelled vertebrae and ribs, each its own value, written as they are.
void PrepRun::record_skeleton() {
  if (labels_.skeleton.data.empty()) return;
  nlohmann::json names = nlohmann::json::object();
  for (std::size_t v = 0; v < labels_.skeleton_names.size(); ++v)
    names[std::to_string(v + 1)] = labels_.skeleton_names[v];
  record_.skeleton = {
      {"file", kSkeletonLabelsFile}, {"source", params_.labels_path}, {"labels", names}};
  write_in_background("bg write skeleton labels", kSkeletonLabelsFile,
                      std::make_shared<Mask>(std::move(labels_.skeleton)));
}

// The map of `mask` into map_ on the CT's grid, upsampled to the maps' grid when refined, then
// (the skin's, when `hu`) projected onto the HU iso-surface at the maps' nodes.
void PrepRun::compute_map(const Mask& mask, const SurfacePoints& points, const CtVolume* hu) {
  const Refinement& refine = record_.refine;
  if (subvoxel_) {
    subvoxel_signed_distance(points, mask, band_, params_.distance.band_mm, map_,
                             params_.distance.threads);
  } else {
    signed_distance(mask, params_.distance, map_);
  }
  if (is_refined(refine)) map_ = upsample_aligned(map_, refine, params_.distance.threads);
  if (subvoxel_ && hu != nullptr)
    record_.projected = project_skin_map(*hu, mask, params_.surface.skin_hu, projection_,
                                         params_.distance.band_mm, map_, params_.distance.threads);
}

// d_surf needs only the CT, the body mask and the skin level: it is computed and written on a
// thread of its own (surf_job_) while this one segments the bone (mostly one core), then its
// buffer serves d_bone.
void PrepRun::start_surface_job() {
  const Grid& grid = ct_owner_->grid;
  subvoxel_ = params_.surface.method == SurfaceMethod::subvoxel;
  band_ = record_.band_mm = subvoxel_band_mm(params_.surface, grid);
  projection_ = record_.projection_mm = skin_projection_mm(params_.surface, grid);
  record_skeleton();
  // The maps' grid: the CT's, or its aligned refinement (--map-spacing; prep/maps/map_refine.hpp).
  record_.refine = map_refinement(result_.grid, params_.map_spacing_mm);
  result_.map_grid = refined_grid(result_.grid, record_.refine);
  surf_ct_ = ct_owner_;
  if (subvoxel_) {
    surf_job_.add("skin points", [&] {
      skin_points_ =
          surface_points(*surf_ct_, body_, params_.surface.skin_hu, params_.distance.threads);
      skin_count_[0] = skin_points_.points.size();
      skin_count_[1] = skin_points_.interpolated;
    });
  }
  surf_job_.add("d_surf", [&] {
    compute_map(body_, skin_points_, subvoxel_ && projection_ != 0.0 ? surf_ct_.get() : nullptr);
    surf_ct_.reset();
    skin_points_ = SurfacePoints{};
    value_range(map_, record_.surf_range, params_.distance.threads);
  });
  surf_job_.add("write d_surf", [&] {
    write_atomically(dir_ / kSurfaceDistanceFile, map_, record_.surf_range[0],
                     record_.surf_range[1]);
  });
}

// The bone levels, shifted with the scan's soft-tissue peak unless given
// (prep/segment/hu_levels.hpp).
void PrepRun::hu_levels() {
  stage("HU levels", [&] {
    result_.hu_levels = estimate_hu_levels(
        *ct_owner_, body_,
        {segmentation_.bone_seed_hu, segmentation_.bone_grow_hu, surface_.bone_hu});
    if (params_.adapt_bone_levels) {
      segmentation_.bone_seed_hu = result_.hu_levels.levels.seed_hu;
      segmentation_.bone_grow_hu = result_.hu_levels.levels.grow_hu;
      surface_.bone_hu = result_.hu_levels.levels.iso_hu;
    }
  });
}

// Contrast-filled lumens: labelled ones replace the search.
void PrepRun::vessels() {
  if (!labels_.vessel.data.empty()) {
    result_.vessel_voxels = count_nonzero(labels_.vessel);
    record_.structures["vessel"] = labelled_vessel_json(labels_, result_.vessel_voxels);
    *vessel_owner_ = std::move(labels_.vessel);
  } else if (params_.find_vessels) {
    stage("vessels", [&] {
      const HuLevels& h = result_.hu_levels;
      const double soft = h.peak_found ? h.soft_peak_hu : kNominalSoftTissueHu + h.offset_hu;
      VesselParams vessels = params_.vessels;  // cortex at the bone mask's own level
      vessels.cortex_margin_hu = segmentation_.bone_lumen_cortex_margin_hu;
      vessels.fat_peak_hu = h.fat_found ? h.fat_peak_hu : kNominalFatHu + h.offset_hu;
      VesselResult v =
          segment_vessels(*ct_owner_, body_, soft, segmentation_.bone_seed_hu, vessels);
      result_.contrast_phase = v.contrast_phase;
      result_.vessel_voxels = v.voxels;
      if (v.voxels > 0) record_.structures["vessel"] = vessel_json(v);
      *vessel_owner_ = std::move(v.lumen);
    });
  }
  has_vessels_ = result_.vessel_voxels > 0;
  if (has_vessels_) write_in_background("bg write vessel", kVesselFile, vessel_owner_);
}

// The bone mask (a label map's bone classes as they are, or segmented) and its points; the CT
// is released here (its writers and d_surf's projection may still hold it).
void PrepRun::bone_mask() {
  const CtVolume& ct = *ct_owner_;
  labelled_bone_ = !labels_.bone.data.empty();
  if (labelled_bone_) {
    *bone_owner_ = std::move(labels_.bone);
  } else {
    stage("bone mask", [&] {
      *bone_owner_ = segment_bone(ct, body_, segmentation_, &result_.stats,
                                  has_vessels_ ? vessel_owner_.get() : nullptr);
    });
  }
  write_in_background("bg write bone", kBoneFile, bone_owner_);
  if (subvoxel_) {
    stage("bone points", [&] {
      bone_points_ = surface_points(ct, bone_, surface_.bone_hu, params_.distance.threads);
    });
  }
  ct_owner_.reset();
  result_.stats.body_voxels = count_nonzero(body_);
  result_.stats.bone_voxels = count_nonzero(bone_);
  record_.structures["bone"] =
      labelled_bone_
          ? labelled_bone_json(labels_, result_.stats.bone_voxels)
          : auto_structure_json("bone", result_.stats.bone_voxels, {kBoneFile, kBoneDistanceFile});
}

void PrepRun::wait_surface_and_writes() {
  std::vector<BackgroundWrites::Done> written;
  stage("wait d_surf", [&] { written = surf_job_.wait(); });
  report_background(written);
  if (subvoxel_) {
    record_.point_counts = {{"skin", {skin_count_[0], skin_count_[1]}},
                            {"bone", {bone_points_.points.size(), bone_points_.interpolated}}};
  }
  // The CT's copy and the masks are out by now (they usually are long before).
  stage("wait CT+masks", [&] { written = writes_.wait(); });
  report_background(written);
}

// d_bone, in d_surf's buffer.
void PrepRun::bone_map() {
  stage("d_bone", [&] { compute_map(bone_, bone_points_, nullptr); });
  bone_points_ = SurfacePoints{};
  value_range(map_, record_.bone_range, params_.distance.threads);
  stage("write d_bone", [&] {
    write_atomically(dir_ / kBoneDistanceFile, map_, record_.bone_range[0], record_.bone_range[1]);
  });
}

// d_vessel (to the mask's faces), in the same buffer, when the scan has vessels.
void PrepRun::vessel_map() {
  if (!has_vessels_) return;
  stage("d_vessel", [&] {
    signed_distance(*vessel_owner_, params_.distance, map_);
    if (is_refined(record_.refine))
      map_ = upsample_aligned(map_, record_.refine, params_.distance.threads);
    value_range(map_, record_.vessel_range, params_.distance.threads);
  });
  vessel_owner_.reset();
  stage("write d_vessel", [&] {
    write_atomically(dir_ / kVesselDistanceFile, map_, record_.vessel_range[0],
                     record_.vessel_range[1]);
  });
}

// One at a time: a CT-sized mask and the maps' buffer.
void PrepRun::structure_maps() {
  if (!structures_.empty()) {
    stage("structures", [&] {
      write_labelled_structures(structures_, result_.grid, params_.distance, record_.refine, dir_,
                                map_, record_.structures, record_.structure_files);
    });
  }
  result_.structures = structure_summaries(record_.structures);
}

// prep.json, written last: until it is there the directory is not a valid cache.
PrepResult PrepRun::finish() {
  result_.total_seconds = std::chrono::duration<double>(Clock::now() - start_).count();
  result_.peak_rss_bytes = peak_rss_bytes();
  write_json_atomically(dir_ / kPrepJsonFile,
                        prep_record_json(result_, params_, segmentation_, surface_, record_, dir_));
  guard_.commit();
  return take_result();
}

}  // namespace

PrepResult run_prep(const std::string& input, const std::string& out_dir, const PrepParams& params,
                    const PrepProgress& progress) {
  check_distance_band(params.distance.band_mm);  // before anything is read or written
  PrepRun run(input, out_dir, params, progress);
  run.create_directory();
  if (run.served_from_cache()) return run.take_result();
  run.forget_previous_run();      // prep.json and structures an earlier run wrote
  run.read_input();               // CT, checked in HU, axis-aligned
  run.read_labels();              // --labels; the CT's copy starts writing
  run.key_inputs();               // input and labels, read and checked -> the cache key
  run.body_mask();                // body mask, written in the background
  run.start_surface_job();        // skin points, d_surf and its write on a thread of their own
  run.hu_levels();                // the bone levels from the soft-tissue peak
  run.vessels();                  // contrast-filled lumens (or the labelled vessels)
  run.bone_mask();                // bone mask and points; the CT released
  run.wait_surface_and_writes();  // d_surf, the CT's copy and the masks are out
  run.bone_map();                 // d_bone, in d_surf's buffer
  run.vessel_map();               // d_vessel, when there are vessels
  run.structure_maps();           // arteries, organs, muscles: <name>, d_<name>
  return run.finish();            // prep.json, last
}

}  // namespace palp
