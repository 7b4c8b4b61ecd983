// Scene loading (see scene.hpp). Stages:
//   resolve     SCENE -> a prep directory (itself, or the cache entry run_prep fills or verifies)
//   read maps   d_surf.nii.gz, d_bone.nii.gz -> two DistanceMaps on one grid, refined in memory
//               when asked (scene_maps.hpp)
//   sampler     DistanceMaps (moved) -> FieldSampler in the configured storage and scheme
#include "scene/scene.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <system_error>
#include <utility>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "prep/maps/map_refine.hpp"
#include "scene/prep_record.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::string env_or_empty(const char* name) {
  const char* value = std::getenv(name);
  return value ? std::string(value) : std::string();
}

// A CT input -> its cache directory, prepped now unless the cache already holds it.
fs::path prep_into_cache(const std::string& input, const SceneOptions& options, bool* prepped) {
  const std::string root =
      options.cache_dir.empty() ? default_scene_cache_dir() : options.cache_dir;
  PrepParams params = options.prep;
  params.use_cache = true;
  const std::string dir = scene_cache_path(input, params, root);
  const PrepResult result = run_prep(input, dir, params, options.progress);
  *prepped = !result.from_cache;
  return dir;
}

// The prep's contrast phase from its prep.json ("" when it records none).
std::string recorded_contrast_phase(const fs::path& dir) {
  const nlohmann::json json = scene_detail::read_prep_record(dir, nullptr);
  if (json.is_discarded()) return {};
  const auto it = json.find("contrast_phase");
  return it != json.end() && it->is_string() ? it->get<std::string>() : std::string();
}

// One layer's map: d_<name>.nii.gz, which must span the scene's maps (the prepped grid, so the
// same scene frame), sampled with the analytic gradient from float32.
StructureLayer read_layer(const fs::path& file, const std::string& name, const Grid& scene) {
  DistanceMap map = read_nifti_float(file.string());
  for (int a = 0; a < 3; ++a) {
    const double extent = map.grid.spacing[a] * static_cast<double>(map.grid.dims[a] - 1);
    const double want = scene.spacing[a] * static_cast<double>(scene.dims[a] - 1);
    if (!(std::fabs(extent - want) <= 1e-3 * std::max(1.0, want)))
      throw InputError(file.string() + ": does not span the scene's maps (" +
                       std::to_string(extent) + " mm against " + std::to_string(want) +
                       " mm along axis " + std::to_string(a) + ")");
  }
  return StructureLayer{name, name == "artery" ? LayerKind::Artery : LayerKind::Organ,
                        std::move(map)};
}

// The layers SceneOptions::layers names that the prep directory has (see there).
void read_layers(const fs::path& dir, const SceneOptions& options, Scene& out) {
  std::error_code ec;
  std::vector<StructureLayer> layers;
  for (const std::string& name : options.layers) {
    fs::path file = dir / ("d_" + name + ".nii.gz");
    std::string source = file.filename().string();
    if (!fs::is_regular_file(file, ec) && name == "artery" &&
        fs::is_regular_file(dir / kVesselDistanceFile, ec) &&
        recorded_contrast_phase(dir) == "arterial") {
      file = dir / kVesselDistanceFile;
      source = std::string(kVesselDistanceFile) + " (arterial phase: its lumens are arteries)";
    }
    if (!fs::is_regular_file(file, ec)) continue;
    layers.push_back(read_layer(file, name, out.grid));
    out.layer_sources.push_back(source);
  }
  out.layers = std::make_shared<const LayerStack>(std::move(layers));
}

}  // namespace

SceneMaps read_scene_maps(const Scene& scene, unsigned threads) {
  return read_scene_maps(scene.prep_dir, scene.map_spacing_mm, threads);
}

bool is_prep_directory(const std::string& path) {
  std::error_code ec;
  const fs::path dir(path);
  if (!fs::is_directory(dir, ec)) return false;
  return fs::exists(dir / kSurfaceDistanceFile, ec) || fs::exists(dir / kPrepJsonFile, ec);
}

std::string default_scene_cache_dir() {
  if (const std::string dir = env_or_empty("PALP_SCENE_CACHE"); !dir.empty()) return dir;
  if (const std::string xdg = env_or_empty("XDG_CACHE_HOME"); !xdg.empty())
    return (fs::path(xdg) / "palp" / "scenes").string();
  if (const std::string home = env_or_empty("HOME"); !home.empty())
    return (fs::path(home) / ".cache" / "palp" / "scenes").string();
  std::error_code ec;
  return (fs::temp_directory_path(ec) / "palp-scenes").string();
}

std::string scene_cache_path(const std::string& input, const PrepParams& params,
                             const std::string& cache_dir) {
  return (fs::path(cache_dir) / prep_cache_key(input, params)).string();
}

Scene load_scene(const std::string& scene, const SceneOptions& options) {
  const auto start = Clock::now();
  if (scene.empty()) throw UsageError("empty scene (give a prep directory, a CT or phantom:NAME)");
  Scene out;
  out.source = scene;
  // resolve: a prep directory is used as is; anything else is a CT input for run_prep.
  const fs::path dir =
      is_prep_directory(scene) ? fs::path(scene) : prep_into_cache(scene, options, &out.prepped);
  out.prep_dir = dir.string();
  // The CT and body mask, for palpd's render volume (a prep directory written before palp kept
  // the CT has none); read once, the refinement below uses them too.
  std::shared_ptr<CtVolume> ct;
  std::shared_ptr<Mask> body;
  std::error_code ec;
  if (options.load_ct && fs::is_regular_file(dir / kCtFile, ec) &&
      fs::is_regular_file(dir / kBodyFile, ec)) {
    ct = std::make_shared<CtVolume>(read_ct((dir / kCtFile).string()));
    body = std::make_shared<Mask>(read_nifti_mask((dir / kBodyFile).string()));
  }
  // read maps: d_surf, d_bone on one grid, refined when asked.
  SceneMaps maps =
      read_scene_maps(out.prep_dir, options.map_spacing_mm, options.threads, ct.get(), body.get());
  out.grid = maps.surf.grid;
  out.map_spacing_mm = options.map_spacing_mm;
  out.map_refinement = maps.refinement;
  out.map_note = maps.note;
  // On the maps' grid, or on the CT grid the maps refine (prep/maps/map_refine.hpp).
  if (ct && refinement_between(ct->grid, out.grid)[0] != 0 && body->grid.dims == ct->grid.dims) {
    out.ct = std::move(ct);
    out.body = std::move(body);
  }
  // sampler: the maps move in (no copy with float32 storage).
  out.fields = std::make_shared<const FieldSampler>(std::move(maps.surf), std::move(maps.bone),
                                                    options.sampler);
  read_layers(dir, options, out);  // d_<layer> -> structure layers
  out.load_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return out;
}

}  // namespace palp
