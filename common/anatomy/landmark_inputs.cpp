// A prep directory's masks and maps as find_landmarks' inputs (landmark_detection.hpp).
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "anatomy/landmark_detection.hpp"
#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "prep/prep.hpp"

namespace palp::anatomy {
namespace {

// prep.json (null when it cannot be read; the file is at most 1 MiB).
nlohmann::json prep_json(const std::filesystem::path& dir) {
  const auto path = dir / kPrepJsonFile;
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec || size > (std::uintmax_t{1} << 20)) return nullptr;
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  auto record = nlohmann::json::parse(text.str(), nullptr, false);
  return record.is_object() ? record : nlohmann::json();
}

// prep.json's contrast phase ("unknown" when it cannot be read).
std::string contrast_phase(const nlohmann::json& record) {
  if (!record.is_object() || !record.contains("contrast_phase") ||
      !record["contrast_phase"].is_string())
    return "unknown";
  return record["contrast_phase"].get<std::string>();
}

// The skeleton's labels prep kept from --labels: the volume (read as floats: a uint8 mask reads
// as 0/1) and its name table (at most 255 names; a value the table does not name is dropped).
void read_skeleton_labels(const std::filesystem::path& dir, const nlohmann::json& record,
                          LandmarkInputs& in) {
  const auto path = dir / kSkeletonLabelsFile;
  if (!record.is_object() || !record.contains("skeleton_labels") || !std::filesystem::exists(path))
    return;
  const nlohmann::json& table = record["skeleton_labels"];
  if (!table.is_object() || !table.contains("labels") || !table["labels"].is_object()) return;
  std::vector<std::string> names(255);
  for (const auto& [key, name] : table["labels"].items()) {
    char* end = nullptr;
    const long v = std::strtol(key.c_str(), &end, 10);
    if (*end == '\0' && v >= 1 && v <= 255 && name.is_string())
      names[static_cast<std::size_t>(v - 1)] = name.get<std::string>();
  }
  while (!names.empty() && names.back().empty()) names.pop_back();
  if (names.empty()) return;
  const DistanceMap values = read_nifti_float(path.string());
  if (values.grid.dims != in.bone.grid.dims) return;
  Mask labels(values.grid, 0, "skeleton labels");
  for (std::size_t i = 0; i < values.data.size(); ++i) {
    const float v = values.data[i];
    if (v >= 1.0f && v <= static_cast<float>(names.size()) &&
        !names[static_cast<std::size_t>(std::lround(v)) - 1].empty())
      labels.data[i] = static_cast<std::uint8_t>(std::lround(v));
  }
  in.skeleton_labels = std::move(labels);
  in.skeleton_names = std::move(names);
}

Mask read_required(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path))
    throw InputError(path.string() + ": missing (not a prep directory? run palp prep first)");
  return read_nifti_mask(path.string());
}

}  // namespace

LandmarkInputs read_landmark_inputs(const std::string& prep_dir, const std::string& scene) {
  const std::filesystem::path dir(prep_dir);
  LandmarkInputs in;
  in.scene = scene;
  in.bone = read_required(dir / kBoneFile);
  in.body = read_required(dir / kBodyFile);
  const auto d_surf = dir / kSurfaceDistanceFile;
  if (!std::filesystem::exists(d_surf)) throw InputError(d_surf.string() + ": missing");
  in.d_surf = read_nifti_float(d_surf.string());
  if (in.body.grid.dims != in.bone.grid.dims)
    throw InputError(prep_dir + ": body.nii.gz and bone.nii.gz are on different grids");
  const nlohmann::json record = prep_json(dir);
  read_skeleton_labels(dir, record, in);
  // The artery: labelled or the phantom's truth (artery.nii.gz), else in an arterial phase the
  // contrast-filled lumens (then the bright ones are arteries).
  const auto artery = dir / "artery.nii.gz";
  const auto vessel = dir / kVesselFile;
  if (std::filesystem::exists(artery)) {
    in.artery = read_nifti_mask(artery.string());
    in.artery_source = "artery.nii.gz";
  } else if (std::filesystem::exists(vessel) && contrast_phase(record) == "arterial") {
    in.artery = read_nifti_mask(vessel.string());
    in.artery_source = "vessel.nii.gz (arterial phase)";
  }
  if (!in.artery.data.empty() && in.artery.grid.dims != in.bone.grid.dims) {
    in.artery = Mask{};
    in.artery_source.clear();
  }
  return in;
}

}  // namespace palp::anatomy
