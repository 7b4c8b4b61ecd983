// Scene loading (see scene.hpp). Stages:
//   resolve     SCENE -> a prep directory (itself, or the cache entry run_prep fills or verifies)
//   read maps   d_surf.nii.gz, d_bone.nii.gz -> two DistanceMaps, grids checked to agree
//   sampler     DistanceMaps (moved) -> FieldSampler in the configured storage and scheme
#include "scene/scene.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <system_error>
#include <utility>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "prep/map_refine.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::string env_or_empty(const char* name) {
  const char* value = std::getenv(name);
  return value ? std::string(value) : std::string();
}

std::string describe_grid(const Grid& grid) {
  char text[160];
  std::snprintf(text, sizeof text, "%lld x %lld x %lld voxels of %g x %g x %g mm",
                static_cast<long long>(grid.dims[0]), static_cast<long long>(grid.dims[1]),
                static_cast<long long>(grid.dims[2]), grid.spacing[0], grid.spacing[1],
                grid.spacing[2]);
  return text;
}

// One map of a prep directory; a missing file is named with what to do about it.
DistanceMap read_map(const fs::path& dir, const char* file) {
  const fs::path path = dir / file;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    throw InputError(dir.string() + ": missing " + file +
                     " (not a complete prep directory; run palp prep)");
  }
  return read_nifti_float(path.string());
}

// The two maps must sample the same points: same dimensions and spacing.
void check_same_grid(const DistanceMap& surf, const DistanceMap& bone, const fs::path& dir) {
  if (surf.grid.dims == bone.grid.dims && surf.grid.spacing == bone.grid.spacing) return;
  throw InputError(dir.string() + ": " + kSurfaceDistanceFile + " (" + describe_grid(surf.grid) +
                   ") and " + kBoneDistanceFile + " (" + describe_grid(bone.grid) +
                   ") are on different grids");
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

}  // namespace

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
  // read maps: d_surf, d_bone on one grid.
  DistanceMap surf = read_map(dir, kSurfaceDistanceFile);
  DistanceMap bone = read_map(dir, kBoneDistanceFile);
  check_same_grid(surf, bone, dir);
  out.grid = surf.grid;
  // The CT and body mask (a prep directory written before palp kept the CT has none).
  std::error_code ec;
  if (options.load_ct && fs::is_regular_file(dir / kCtFile, ec) &&
      fs::is_regular_file(dir / kBodyFile, ec)) {
    auto ct = std::make_shared<CtVolume>(read_ct((dir / kCtFile).string()));
    auto body = std::make_shared<Mask>(read_nifti_mask((dir / kBodyFile).string()));
    // On the maps' grid, or on the CT grid the maps refine (prep/map_refine.hpp).
    if (refinement_between(ct->grid, out.grid)[0] != 0 && body->grid.dims == ct->grid.dims) {
      out.ct = std::move(ct);
      out.body = std::move(body);
    }
  }
  // sampler: the maps move in (no copy with float32 storage).
  out.fields =
      std::make_shared<const FieldSampler>(std::move(surf), std::move(bone), options.sampler);
  out.load_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return out;
}

}  // namespace palp
