// prep's structures beyond the body (internal to prep): the files of a label map's arteries,
// organs and muscles, and of a phantom's own truth (its artery and liver), <name>.nii.gz (uint8
// 0/1) and d_<name>.nii.gz (float32 mm, positive inside), written one at a time; prep.json's
// record of where each structure came from; the outputs an earlier prep in the directory
// recorded; and the atomic writes every output goes through.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include "base/errors.hpp"
#include "base/volume.hpp"
#include "io/ct_io.hpp"
#include "prep/labels/label_maps.hpp"
#include "prep/maps/distance_transform.hpp"
#include "prep/maps/map_refine.hpp"
#include "prep/prep.hpp"

namespace palp {

// Writes to a temporary name and renames, so an interrupted run never leaves a half file under
// the final name. `extra`: what else write_nifti takes (a map's value range, found already).
template <class V, class... Extra>
void write_atomically(const std::filesystem::path& path, const V& volume, const Extra&... extra) {
  const std::filesystem::path partial = path.string() + ".partial.nii.gz";
  write_nifti(partial.string(), volume, extra...);
  std::error_code ec;
  std::filesystem::rename(partial, path, ec);
  if (ec) throw Error(path.string() + ": cannot be written: " + ec.message());
}

// The smallest and largest value of a map, in parallel (the maps hold 10^8 voxels).
void value_range(const DistanceMap& map, float range[2], unsigned threads);

// A labelled structure's files: <name>.nii.gz and d_<name>.nii.gz.
std::string structure_file(const std::string& name);
std::string structure_distance_file(const std::string& name);
// Both files of every structure, for the output guard.
std::vector<std::string> structure_files(const std::vector<LabelledStructure>& structures);

// The files the prep.json in `dir` recorded (its file_bytes; none when there is no readable
// prep.json): plain .nii.gz names only, never a path.
std::vector<std::string> recorded_outputs(const std::filesystem::path& dir);
// Removes the files `recorded` names from `dir`, except prep's own fixed outputs (each run
// writes them again) and a file that is the CT input or the label map: an earlier run's
// <name>.nii.gz is not mistaken for this run's.
void remove_stale_outputs(const std::filesystem::path& dir,
                          const std::vector<std::string>& recorded, const std::string& input,
                          const std::string& labels_path);

// prep.json's records (its "structures"): {"kind", "source", "voxels", "files"}, source "auto"
// or the label map's {"file", "format", "classes", "resampled", "note"}.
nlohmann::json auto_structure_json(const char* kind, std::uint64_t voxels,
                                   std::vector<std::string> files);
nlohmann::json labelled_bone_json(const LabelMaps& maps, std::uint64_t voxels);
// The vessel's classes are the arteries', veins' and other vessels'; "split" keeps each kind's
// classes and voxels.
nlohmann::json labelled_vessel_json(const LabelMaps& maps, std::uint64_t voxels);

// The label map's arteries as a structure of their own: "artery", kind "artery" (artery.nii.gz,
// d_artery.nii.gz, written as an organ is), cut to their box of CT voxels, its source the label
// map's artery classes; none when the map has no artery class. Frees maps.artery (the vessel mask
// keeps the arteries, with the veins).
std::optional<LabelledStructure> labelled_artery(LabelMaps& maps);

// Whether `input` is a phantom that draws its own truth of the structures beyond bone
// (phantom:torso,...,structures; io/phantom.hpp): prep takes its artery and liver from that truth,
// as a lab's label map would give them (the phantom is its own expert).
bool phantom_draws_structures(const std::string& input);
// The CT of `input`, as read_ct reads it. When `truth` is given and phantom_draws_structures, the
// phantom's truth is drawn with it and `truth` receives its artery ("artery", kind "artery") and
// its liver ("liver", kind "organ"), each cut to its box, source {"format": "phantom-truth",
// "phantom": input, "truth": the truth mask's name}.
CtVolume read_ct_with_truth(const std::string& input, std::vector<LabelledStructure>* truth);

// Writes each structure's mask and map into `dir`, one at a time (one CT-sized mask and `map`,
// the maps' buffer), freeing each structure's box once written: the map is the mask's signed
// distance (to its voxel faces), on the maps' grid when `refine` refines the CT's. Adds each
// structure's record to `records` (with its files and map range) and its files to `files`.
void write_labelled_structures(std::vector<LabelledStructure>& structures, const Grid& ct_grid,
                               const DistanceParams& distance, const Refinement& refine,
                               const std::filesystem::path& dir, DistanceMap& map,
                               nlohmann::json& records, std::vector<std::string>& files);

// prep.json's "structures" -> the summary: bone, vessel, artery, then the rest by name.
std::vector<PrepStructure> structure_summaries(const nlohmann::json& records);

}  // namespace palp
