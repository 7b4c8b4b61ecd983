// Shared setup of the model commands (see model_setup.hpp).
#include "cli_common/model_setup.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>

#include "base/errors.hpp"
#include "model/field_sampler.hpp"

namespace palp::cli {

std::vector<std::string> take_repeated(Arguments& argv, const std::string& key) {
  std::vector<std::string> values;
  Arguments rest;
  const std::string flag = "--" + key;
  for (std::size_t i = 0; i < argv.size(); ++i) {
    const std::string& arg = argv[i];
    if (arg == flag) {
      if (i + 1 >= argv.size()) throw UsageError("option " + flag + " needs a value");
      values.push_back(argv[++i]);
    } else if (arg.rfind(flag + "=", 0) == 0) {
      values.push_back(arg.substr(flag.size() + 1));
    } else {
      rest.push_back(arg);
    }
  }
  argv = std::move(rest);
  return values;
}

ModelKind model_kind(const Args& args) {
  return parse_model_kind(args.get("model").value_or("palp"));
}

SceneOptions scene_options(const Args& args) {
  SceneOptions options;
  // palp's continuous normals: the precomputed gradient, trilinearly interpolated, with both maps
  // and gradients in one record per voxel so the tick samples them in one pass (same outputs as
  // float32, bit for bit; docs/force_model.md "Tick cost")
  if (model_kind(args) == ModelKind::Palp) {
    options.sampler.gradient = GradientScheme::PrecomputedField;
    options.sampler.storage = Storage::Interleaved;
    // and on a coarse CT its maps refined in memory (scene/scene_maps.hpp)
    options.map_spacing_mm = kPalpMapSpacingMm;
  }
  if (const auto scheme = args.get("scheme"))
    options.sampler.gradient = parse_gradient_scheme(*scheme);
  if (const auto storage = args.get("storage")) options.sampler.storage = parse_storage(*storage);
  options.map_spacing_mm = args.number("map-spacing", options.map_spacing_mm);
  if (!(options.map_spacing_mm >= 0.0 && options.map_spacing_mm <= 100.0))
    throw UsageError("--map-spacing needs 0 (the maps as prepped) or a spacing in mm up to 100");
  if (const auto layers = args.get("layers")) {
    options.layers.clear();
    std::size_t begin = 0;
    while (*layers != "none" && begin <= layers->size()) {
      const std::size_t end = std::min(layers->find(',', begin), layers->size());
      const std::string name = layers->substr(begin, end - begin);
      if (name.empty() || name.find_first_of("/\\.") != std::string::npos)
        throw UsageError("--layers needs structure names (artery, liver, ...) or none, got '" +
                         *layers + "'");
      options.layers.push_back(name);
      begin = end + 1;
    }
  }
  if (const auto dir = args.get("cache-dir")) {
    if (dir->empty()) throw UsageError("--cache-dir needs a directory");
    options.cache_dir = *dir;
  }
  return options;
}

Scene load_scene_for(const Args& args, const std::string& command, bool quiet) {
  const auto scene_name = args.get("scene");
  if (!scene_name) throw UsageError(command + " needs --scene SCENE");
  SceneOptions options = scene_options(args);
  options.load_ct = command == "palpd";  // palpd ships the CT in its render volume
  if (!quiet) {
    options.progress = [](const std::string& stage, bool finished, double seconds) {
      if (!finished) std::fprintf(stderr, "  prep %-14s ...", stage.c_str());
      if (finished) std::fprintf(stderr, " %7.3f s\n", seconds);
      std::fflush(stderr);
    };
  }
  Scene scene = load_scene(*scene_name, options);
  if (!quiet) {
    std::fprintf(stderr, "scene %s: %s%s, %.3f s (%s, %s)\n", scene_name->c_str(),
                 scene.prep_dir.c_str(), scene.prepped ? " (prepped now)" : "", scene.load_seconds,
                 to_string(scene.fields->config().gradient),
                 to_string(scene.fields->config().storage));
    if (is_refined(scene.map_refinement)) {
      const Grid& g = scene.grid;
      std::fprintf(stderr,
                   "scene maps refined in memory (--map-spacing %g): %lldx%lldx%lld nodes of "
                   "%.3g x %.3g x %.3g mm\n",
                   scene.map_spacing_mm, static_cast<long long>(g.dims[0]),
                   static_cast<long long>(g.dims[1]), static_cast<long long>(g.dims[2]),
                   g.spacing[0], g.spacing[1], g.spacing[2]);
    }
  }
  for (std::size_t i = 0; !quiet && i < scene.layers->size(); ++i)
    std::fprintf(stderr, "scene layer %s (%s): %s\n", scene.layers->name(i).c_str(),
                 to_string(scene.layers->kind(i)), scene.layer_sources[i].c_str());
  if (!quiet && !scene.map_note.empty())
    std::fprintf(stderr, "scene: note: %s\n", scene.map_note.c_str());
  return scene;
}

ForceParams force_params(ModelKind model, const Tool& tool,
                         const std::vector<std::string>& assignments) {
  ForceParams params = model_params(model, tool.kind);
  for (const std::string& assignment : assignments) {
    const auto eq = assignment.find('=');
    if (eq == std::string::npos || eq == 0)
      throw UsageError("--param needs NAME=VALUE, got '" + assignment + "'");
    const std::string name = assignment.substr(0, eq);
    const std::string text = assignment.substr(eq + 1);
    double value = 0.0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (text.empty() || ec != std::errc() || end != text.data() + text.size() ||
        !std::isfinite(value)) {
      throw UsageError("--param " + name + " needs a number, got '" + text + "'");
    }
    set_param(params, name, value);
  }
  return params;
}

}  // namespace palp::cli
