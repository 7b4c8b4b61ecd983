// A prep directory's masks and maps as find_landmarks' inputs (landmark_detection.hpp).
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

// prep.json's contrast phase ("unknown" when it cannot be read; the file is at most 1 MiB).
std::string contrast_phase(const std::filesystem::path& dir) {
  const auto path = dir / kPrepJsonFile;
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec || size > (std::uintmax_t{1} << 20)) return "unknown";
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  const auto json = nlohmann::json::parse(text.str(), nullptr, false);
  if (!json.is_object() || !json.contains("contrast_phase") || !json["contrast_phase"].is_string())
    return "unknown";
  return json["contrast_phase"].get<std::string>();
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
  // The artery: labelled or the phantom's truth (artery.nii.gz), else in an arterial phase the
  // contrast-filled lumens (then the bright ones are arteries).
  const auto artery = dir / "artery.nii.gz";
  const auto vessel = dir / kVesselFile;
  if (std::filesystem::exists(artery)) {
    in.artery = read_nifti_mask(artery.string());
    in.artery_source = "artery.nii.gz";
  } else if (std::filesystem::exists(vessel) && contrast_phase(dir) == "arterial") {
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
