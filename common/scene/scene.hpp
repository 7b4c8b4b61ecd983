// A scene: the constant, sampled distance maps the force model runs on, loaded from
//   - a prep directory (d_surf.nii.gz and d_bone.nii.gz, as `palp prep` writes them), or
//   - any CT input `palp prep` accepts (a .nii/.nii.gz/.mha/.mhd/.nrrd/.nhdr file, a DICOM series
//     directory, or phantom:NAME), which is prepped first into a cache directory keyed by
//     prep_cache_key(input, parameters), so a second load only reads the maps back.
//
// Data flow: SCENE -> (run_prep into the cache, if not a prep directory) -> d_surf, d_bone
// (DistanceMap, float32 mm; refined in memory on a coarse CT, scene_maps.hpp) -> FieldSampler
// (the chosen storage and gradient scheme).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "base/volume.hpp"
#include "model/field_sampler.hpp"
#include "model/structure_layers.hpp"
#include "prep/prep.hpp"
#include "scene/scene_maps.hpp"

namespace palp {

struct SceneOptions {
  SamplerConfig sampler;  // storage and gradient scheme of the FieldSampler
  PrepParams prep;        // used when the scene is a CT input that still has to be prepped
  std::string cache_dir;  // where CT inputs are prepped; empty = default_scene_cache_dir()
  PrepProgress progress;  // reports prep stages of a CT input (not called for a cache hit)
  bool load_ct = false;   // also read the CT (ct.nii.gz) and body mask, when the directory has them
  // The maps in memory on the CT's grid refined to at most this spacing (mm) where it is coarser
  // (scene_maps.hpp); 0 = as prepped. The commands give palp's model kPalpMapSpacingMm.
  double map_spacing_mm = 0.0;
  unsigned threads = 0;  // of the refinement; 0 = default_thread_count()
  // The structures loaded as force layers (model/structure_layers.hpp) when the prep directory
  // has their d_<name>.nii.gz: "artery" pulses, any other name is an organ border. Without
  // d_artery.nii.gz, a scan whose contrast_phase is "arterial" gives its d_vessel.nii.gz as the
  // artery (in that phase the lumens that are bright are arteries). Empty: bone only.
  std::vector<std::string> layers = {"artery", "liver"};
};

// The in-memory map spacing of the palp model (mm): a 3 mm CT's maps at 1.5 mm, so the skin's
// distance between the CT's nodes is its own and not a trilinear blend (docs/force_model.md
// "Finer maps in memory"); the torso phantom (<= 2 mm) and finer CTs stay as prepped.
inline constexpr double kPalpMapSpacingMm = 2.0;

struct Scene {
  std::string source;           // the SCENE as given
  std::string prep_dir;         // the directory the maps were read from
  bool prepped = false;         // the CT input was prepped during this load (not served from cache)
  Grid grid;                    // the maps' grid (dims, spacing, the input's world placement)
  double map_spacing_mm = 0.0;  // SceneOptions::map_spacing_mm, for read_scene_maps(Scene)
  Refinement map_refinement{1, 1, 1};  // applied in memory (all 1: the maps as prepped)
  std::string map_note;                // why asked-for refinement was not done ("" otherwise)
  double load_seconds = 0.0;
  std::shared_ptr<const FieldSampler> fields;
  // The structure layers found (in SceneOptions::layers' order), each map on its own grid in the
  // scene frame, and where each came from ("d_artery.nii.gz", "d_vessel.nii.gz (arterial)").
  std::vector<StructureLayer> layers;
  std::vector<std::string> layer_sources;
  // With SceneOptions::load_ct, from a prep directory that has them (null otherwise): the CT's
  // HU and the body mask on the maps' grid, or on the coarse CT grid the maps refine
  // (prep/maps/map_refine.hpp).
  std::shared_ptr<const CtVolume> ct;
  std::shared_ptr<const Mask> body;
};

// Loads SCENE (see the top of this file). Throws InputError for a prep directory with missing
// or unreadable maps, or maps on different grids; UsageError for an input that is neither a prep
// directory nor a CT input; the errors of run_prep for CT inputs.
Scene load_scene(const std::string& scene, const SceneOptions& options = {});

// The scene's maps again as its sampler has them (refined as at load), for a sampler of another
// storage or a window of them.
SceneMaps read_scene_maps(const Scene& scene, unsigned threads = 0);

// True when `path` is a directory holding a prep result (d_surf.nii.gz or prep.json in it).
bool is_prep_directory(const std::string& path);

// The scene cache: $PALP_SCENE_CACHE, else $XDG_CACHE_HOME/palp/scenes, else
// $HOME/.cache/palp/scenes, else <temp>/palp-scenes.
std::string default_scene_cache_dir();

// Where load_scene preps a CT input: <cache_dir>/<prep_cache_key(input, params)>.
std::string scene_cache_path(const std::string& input, const PrepParams& params,
                             const std::string& cache_dir);

}  // namespace palp
