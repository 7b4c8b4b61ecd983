// prep's scene cache key and validity (see prep_cache.hpp).
#include "prep/prep_cache.hpp"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <system_error>
#include <vector>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "io/gzip.hpp"
#include "io/nrrd.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;

// A stable 64-bit hash of byte streams (not cryptographic: it detects changed inputs). With
// read_files false it opens the files it is given, with every check of that open, and reads none.
class ContentHash {
 public:
  explicit ContentHash(bool read_files = true) : read_files_(read_files) {}
  void add(const void* bytes, std::size_t size) {
    const auto* p = static_cast<const unsigned char*>(bytes);
    std::size_t i = 0;
    for (; i + 8 <= size; i += 8) {
      std::uint64_t word;
      std::memcpy(&word, p + i, 8);
      mix(word);
    }
    std::uint64_t tail = 0;
    std::memcpy(&tail, p + i, size - i);
    mix(tail ^ (static_cast<std::uint64_t>(size - i) << 56));
    mix(size);
  }
  void add(const std::string& text) { add(text.data(), text.size()); }
  // Reads through DecodedReader: only regular files, opened without blocking (a FIFO would wait
  // for a writer, /dev/zero never ends), a symlink loop named as one.
  void add_file(const fs::path& path) {
    DecodedReader in(path.string(), 0, Compression::none);
    if (!read_files_) return;
    std::vector<char> buffer(1 << 20);
    for (;;) {
      const std::size_t got = in.read(buffer.data(), buffer.size());
      add(buffer.data(), got);
      if (got < buffer.size()) break;
    }
  }
  std::string hex() const {
    char text[17];
    std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(state_));
    return text;
  }

 private:
  void mix(std::uint64_t word) {
    state_ ^= word + 0x9e3779b97f4a7c15ull + (state_ << 6) + (state_ >> 2);
    state_ *= 0xff51afd7ed558ccdull;
    state_ ^= state_ >> 33;
  }
  bool read_files_ = true;
  std::uint64_t state_ = 0xcbf29ce484222325ull;
};

// Every regular file of a directory (a DICOM series, a TotalSegmentator folder), in name order,
// name and bytes: as the readers do, what is not a regular file (a symlink loop too) is skipped.
void hash_directory_files(ContentHash& hash, const fs::path& dir) {
  std::error_code ec;
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir, ec))
    if (std::error_code entry_ec; entry.is_regular_file(entry_ec)) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  for (const auto& file : files) {
    hash.add(file.filename().string());
    hash.add_file(file);
  }
}

void hash_input(ContentHash& hash, const std::string& input) {
  if (input.rfind("phantom:", 0) == 0) {
    hash.add(input);
    return;
  }
  const fs::path path(input);
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    hash_directory_files(hash, path);
    return;
  }
  // "no such file or directory", "a loop of symbolic links" (not "no such file": fs::exists
  // says false for both), or what it is instead of a regular file
  require_regular_file(input);
  hash.add_file(path);
  // A detached header (.mhd, .nhdr) names the file with the voxels: the key follows those too.
  const std::string voxel_file = ct_voxel_file(input);
  if (voxel_file != input) hash.add_file(voxel_file);
}

// A label map's bytes: the file (and a detached .nhdr's data file), or every regular file of a
// TotalSegmentator folder in name order. A missing one is refused as the label reader would.
void hash_labels(ContentHash& hash, const std::string& labels) {
  const fs::path path(labels);
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError("labels: " + labels + ": no such file or directory");
  if (fs::is_directory(path, ec)) {
    hash_directory_files(hash, path);
    return;
  }
  try {
    require_regular_file(labels);
    hash.add_file(path);
    std::string name = path.filename().string();
    for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (name.ends_with(".nhdr")) {
      const std::string data = read_nrrd_layered_header(labels).image.voxels.path;
      if (data != labels) hash.add_file(data);
    }
  } catch (const InputError& e) {
    throw InputError(std::string("labels: ") + e.what());
  }
}

}  // namespace

namespace {

nlohmann::json labels_params_json(const PrepParams& params) {
  if (params.labels_path.empty()) return "none";
  return {{"path", params.labels_path},
          {"map", params.labels_map.empty() ? "by the file's names" : params.labels_map}};
}

nlohmann::json vessel_params_json(const PrepParams& params) {
  if (!params.find_vessels) return "off";
  const VesselParams& v = params.vessels;
  return {{"min_contrast_hu", v.min_contrast_hu},
          {"min_lumen_contrast_hu", v.min_lumen_contrast_hu},
          {"trunk_core_mm", v.trunk_core_mm},
          {"split_mm", v.split_mm},
          {"max_pool_margin_hu", v.max_pool_margin_hu},
          {"ridge_drop", v.ridge_drop},
          {"clear_contrast_hu", v.clear_contrast_hu},
          {"max_cortex_contact", v.max_cortex_contact},
          {"max_clear_contrast_contact", v.max_clear_contrast_contact},
          {"max_spread_fraction", v.max_spread_fraction},
          {"min_lumen_ml", v.min_lumen_ml},
          {"closing_mm", v.closing_mm},
          {"arterial_above_soft_hu", v.arterial_above_soft_hu}};
}

}  // namespace

nlohmann::json params_json(const PrepParams& params) {
  const SegmentationParams& s = params.segmentation;
  return {{"body_threshold_hu", s.body_threshold_hu},
          {"min_body_part_ml", s.min_body_part_ml},
          {"body_core_radius_mm", s.body_core_radius_mm},
          {"max_table_thickness_mm", s.max_table_thickness_mm},
          {"min_table_width_mm", s.min_table_width_mm},
          {"bone_seed_hu", s.bone_seed_hu},
          {"bone_grow_hu", s.bone_grow_hu},
          {"bone_leak_contact_fraction", s.bone_leak_contact_fraction},
          {"bone_lumen_cortex_margin_hu", s.bone_lumen_cortex_margin_hu},
          {"bone_lumen_max_contact", s.bone_lumen_max_contact},
          {"bone_lumen_radius_mm", s.bone_lumen_radius_mm},
          {"bone_marrow_votes", s.bone_marrow_votes},
          {"bone_max_hole_mm2", s.bone_max_hole_mm2},
          {"bone_enclosure_radius_mm", s.bone_enclosure_radius_mm},
          {"bone_enclosure_directions", s.bone_enclosure_directions},
          {"bone_plate_radius_mm", s.bone_plate_radius_mm},
          {"bone_edge_fraction", s.bone_edge_fraction},
          {"bone_notch_faces", s.bone_notch_faces},
          {"bone_max_cavity_ml", s.bone_max_cavity_ml},
          {"bone_marrow_behind_lumens", s.bone_marrow_behind_lumens},
          {"min_bone_island_ml", s.min_bone_island_ml},
          {"bone_calculus_max_length_mm", s.bone_calculus_max_length_mm},
          {"bone_rib_depth_mm", s.bone_rib_depth_mm},
          {"bone_skin_clearance_mm", s.bone_skin_clearance_mm},
          {"distance_band_mm", params.distance.band_mm},
          {"surface", surface_method_name(params.surface.method)},
          {"skin_iso_hu", params.surface.skin_hu},
          {"bone_iso_hu", params.surface.bone_hu},
          {"subvoxel_band_mm", params.surface.band_mm},
          {"skin_projection_mm", params.surface.skin_projection_mm},
          {"map_spacing_mm", params.map_spacing_mm},
          {"bone_levels", params.adapt_bone_levels ? "adapted" : "as given"},
          {"vessels", vessel_params_json(params)},
          {"labels", labels_params_json(params)}};
}

bool cache_is_valid(const fs::path& out_dir, const std::string& key, nlohmann::json* cached) {
  std::ifstream in(out_dir / kPrepJsonFile);
  if (!in) return false;
  const nlohmann::json json = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded() || json.value("cache_key", "") != key) return false;
  if (!json.contains("file_bytes") || !json["file_bytes"].is_object()) return false;
  for (const char* name :
       {kBodyFile, kBoneFile, kSurfaceDistanceFile, kBoneDistanceFile, kCtFile}) {
    if (!json["file_bytes"].contains(name)) return false;
  }
  // Every file the run wrote (the structures beyond bone too) is there at the size it wrote.
  for (const auto& [name, bytes] : json["file_bytes"].items()) {
    std::error_code ec;
    const auto size = fs::file_size(out_dir / name, ec);
    if (ec || name.find('/') != std::string::npos || bytes != size) return false;
  }
  *cached = json;
  return true;
}

void check_prep_inputs(const std::string& input, const PrepParams& params) {
  ContentHash opens_only(false);
  hash_input(opens_only, input);
  if (!params.labels_path.empty()) hash_labels(opens_only, params.labels_path);
}

std::string prep_cache_key(const std::string& input, const PrepParams& params) {
  ContentHash hash;
  hash.add("palp-prep-v" + std::to_string(kPrepAlgorithmVersion));
  hash.add(params_json(params).dump());
  hash_input(hash, input);
  if (!params.labels_path.empty()) {
    hash.add("labels");
    hash_labels(hash, params.labels_path);
  }
  return hash.hex();
}

}  // namespace palp
