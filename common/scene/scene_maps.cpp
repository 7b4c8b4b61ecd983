// A prep directory's maps, refined in memory on a coarse CT (see scene_maps.hpp). Stages:
//   read maps   d_surf.nii.gz, d_bone.nii.gz -> two DistanceMaps, grids checked to agree
//   decide      map_spacing_mm, the maps' grid, prep.json, ct.nii.gz -> factors k, or a note why
//   not upsample    both maps -> the CT's grid refined by k (the same trilinear functions) project
//   d_surf's skin band at the fine nodes -> the distance to the HU's iso-surface
#include "scene/scene_maps.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <system_error>
#include <utility>

#include <nlohmann/json.hpp>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "prep/prep.hpp"
#include "scene/prep_record.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;

// prep.json is a few kB; a larger one is not ours and is not parsed.

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

// What prep.json says of d_surf's surface: its skin level, the projection's reach and the
// maps' clamp. Empty `why` when the skin can be projected again at finer nodes.
struct SkinSurface {
  double skin_hu = 0.0, reach_mm = 0.0, clamp_mm = 0.0;
  std::string why;
};

SkinSurface skin_surface(const fs::path& dir) {
  SkinSurface s;
  std::string why;
  const nlohmann::json json = scene_detail::read_prep_record(dir, &why);
  if (json.is_discarded()) return {0, 0, 0, why};
  const nlohmann::json* params =
      json.contains("parameters") && json["parameters"].is_object() ? &json["parameters"] : nullptr;
  if (!params || params->value("surface", std::string()) != "subvoxel")
    return {0, 0, 0, "maps prepped to the masks' faces (--surface mask), not the HU's surface"};
  const auto number = [](const nlohmann::json& j, const char* key) {
    return j.contains(key) && j[key].is_number() ? j[key].get<double>() : 0.0;
  };
  s.skin_hu = number(*params, "skin_iso_hu");
  s.clamp_mm = number(*params, "distance_band_mm");
  if (json.contains("skin_projection") && json["skin_projection"].is_object())
    s.reach_mm = number(json["skin_projection"], "reach_mm");
  if (!(s.reach_mm > 0.0 && s.reach_mm <= 1000.0))
    return {0, 0, 0, "prep.json records no skin projection (--skin-projection 0 or an old prep)"};
  if (!(s.clamp_mm > 0.0 && s.clamp_mm <= 10000.0) || !(std::abs(s.skin_hu) <= 1e5))
    return {0, 0, 0, "prep.json's skin level or distance band is missing"};
  return s;
}

}  // namespace

SceneMaps read_scene_maps(const std::string& dir_name, double map_spacing_mm, unsigned threads,
                          const CtVolume* given_ct, const Mask* given_body) {
  const fs::path dir(dir_name);
  SceneMaps out;
  // read maps: d_surf, d_bone on one grid.
  out.surf = read_map(dir, kSurfaceDistanceFile);
  out.bone = read_map(dir, kBoneDistanceFile);
  check_same_grid(out.surf, out.bone, dir);
  // decide: refine only a grid coarser than asked, with what the skin's projection needs.
  if (!(map_spacing_mm > 0.0)) return out;
  const Refinement k = map_refinement(out.surf.grid, map_spacing_mm);
  if (!is_refined(k)) return out;
  const SkinSurface skin = skin_surface(dir);
  if (!skin.why.empty()) {
    out.note = "maps not refined: " + skin.why;
    return out;
  }
  CtVolume read_ct_volume;
  Mask read_body;
  if (!given_ct || !given_body) {
    std::error_code ec;
    if (!fs::is_regular_file(dir / kCtFile, ec) || !fs::is_regular_file(dir / kBodyFile, ec)) {
      out.note = std::string("maps not refined: no ") + kCtFile + " and " + kBodyFile +
                 " in the prep directory (prepped before palp kept the CT)";
      return out;
    }
    read_ct_volume = read_ct((dir / kCtFile).string());
    read_body = read_nifti_mask((dir / kBodyFile).string());
  }
  const CtVolume& ct = given_ct && given_body ? *given_ct : read_ct_volume;
  const Mask& body = given_ct && given_body ? *given_body : read_body;
  if (refinement_between(ct.grid, out.surf.grid) != Refinement{1, 1, 1} ||
      body.grid.dims != ct.grid.dims) {
    out.note = "maps not refined: they are not on the CT's own grid (prepped with --map-spacing)";
    return out;
  }
  // upsample: the same trilinear functions on the fine nodes.
  out.surf = upsample_aligned(out.surf, k, threads);
  out.bone = upsample_aligned(out.bone, k, threads);
  // project: the skin band's fine nodes take their distance to the HU's iso-surface.
  out.projected =
      project_skin_map(ct, body, skin.skin_hu, skin.reach_mm, skin.clamp_mm, out.surf, threads);
  out.refinement = k;
  return out;
}

}  // namespace palp
