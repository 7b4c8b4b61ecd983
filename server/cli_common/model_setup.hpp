// Options shared by the commands that run the force model (run, bench, traj): the scene, the
// sampler's scheme and storage, the tool and --param overrides.
#pragma once

#include <string>
#include <vector>

#include "cli_common/cli.hpp"
#include "model/force_model.hpp"
#include "model/tool.hpp"
#include "scene/scene.hpp"

namespace palp::cli {

// Valued options every model command accepts (besides its own).
inline const std::vector<std::string> kSceneOptions = {
    "scene", "scheme", "storage", "cache-dir", "model", "map-spacing", "layers"};

// Help text of those options.
inline constexpr const char* kSceneOptionsHelp =
    R"(  --scene SCENE           a prep directory, a CT (.nii/.nii.gz/.mha/.mhd/.nrrd/.nhdr, DICOM
                          directory) or phantom:NAME; CTs are prepped once into the cache
  --model NAME            force model: palp (default; docs/force_model.md) or paper (the
                          paper's equations as printed, bit for bit)
  --scheme NAME           gradient: analytic, central, precomputed (default: precomputed for
                          --model palp, analytic for --model paper)
  --storage NAME          maps in memory: float32, int16, interleaved (default: interleaved
                          for --model palp, float32 for --model paper)
  --map-spacing MM        the maps in memory on the CT's grid refined to at most MM where it is
                          coarser, the skin's band projected onto the CT's own surface at the
                          new nodes (default 2 for --model palp: a 3 mm CT's maps at 1.5 mm;
                          0 = as prepped, the default for --model paper)
  --layers LIST           structures felt besides skin and bone when the scene has their maps
                          (palp model): artery (pulses), liver or any prepped organ, comma-
                          separated; none = bone only (default: artery,liver)
  --cache-dir DIR         scene cache (default $PALP_SCENE_CACHE, else
                          $XDG_CACHE_HOME/palp/scenes, else ~/.cache/palp/scenes)
)";

// Removes every "--KEY VALUE" / "--KEY=VALUE" from argv (for repeatable options the parser
// would otherwise overwrite) and returns the values in order. UsageError for a missing value.
std::vector<std::string> take_repeated(Arguments& argv, const std::string& key);

// The force model of parsed arguments (--model; default palp).
ModelKind model_kind(const Args& args);

// The scene options of parsed arguments (--scheme, --storage, --map-spacing, --cache-dir; the
// scheme's, the storage's and the map spacing's defaults follow --model).
SceneOptions scene_options(const Args& args);

// Loads --scene (required: UsageError naming `command` otherwise), reporting on stderr unless
// quiet: where the maps came from and how long it took.
Scene load_scene_for(const Args& args, const std::string& command, bool quiet);

// The model's parameters for the tool kind (model_params) with NAME=VALUE overrides applied in
// order.
ForceParams force_params(ModelKind model, const Tool& tool,
                         const std::vector<std::string>& assignments);

}  // namespace palp::cli
