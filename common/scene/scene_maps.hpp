// A prep directory's two distance maps as the force model reads them: as prepped, or refined in
// memory on a coarse CT (the palp model's default, issue 14's skin at 6 mm on a 3 mm CT).
//
// Data flow: d_surf.nii.gz, d_bone.nii.gz (the CT's grid, spec "Files") -> both upsampled
// trilinearly onto the CT's grid refined to at most `map_spacing_mm` (prep/maps/map_refine.hpp: the
// same functions as before) -> d_surf's skin band projected onto the trilinear HU's iso-surface
// at the fine nodes (prep/maps/iso_projection.hpp, with prep.json's skin level and reach; needs
// ct.nii.gz and body.nii.gz). The files stay what the spec fixes; only what the tick reads is
// finer, so between the CT's nodes the skin's distance is the exact one, not a trilinear blend of
// 3 mm nodes (docs/force_model.md "Finer maps in memory").
#pragma once

#include <string>

#include "base/volume.hpp"
#include "prep/maps/iso_projection.hpp"
#include "prep/maps/map_refine.hpp"

namespace palp {

struct SceneMaps {
  DistanceMap surf, bone;
  Refinement refinement{1, 1, 1};  // applied in memory (all 1: the maps as prepped)
  IsoProjectionStats projected;    // d_surf's nodes within reach, and those projected
  // Why refinement was asked for and not done ("" when done or not asked for): the maps' grid is
  // fine enough already, the directory has no CT, the surface is the masks' ...
  std::string note;
};

// The maps of prep directory `dir` (InputError for a missing or unreadable map, or two maps on
// different grids), refined in memory when map_spacing_mm > 0 and the maps' grid is coarser
// than it along some axis. A directory that cannot be refined (no ct.nii.gz or body.nii.gz, maps
// prepped with --surface mask or no skin projection, maps not on the CT's grid) gives its maps
// as they are and says why in `note`. `ct` and `body`: the directory's ct.nii.gz and body.nii.gz
// when the caller has read them already (palpd keeps them for its render volume), so they are
// not read twice; both null: read here when needed.
SceneMaps read_scene_maps(const std::string& dir, double map_spacing_mm, unsigned threads = 0,
                          const CtVolume* ct = nullptr, const Mask* body = nullptr);

}  // namespace palp
