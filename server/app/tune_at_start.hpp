// palpd --tune: at start, the cheapest configuration (tool's contact points, gradient scheme,
// map storage) whose forces a hand cannot tell from the most accurate one (common/tune/tuner.hpp,
// as `palp tune`), bounded in time and cached.
//
//   scene (prep dir) + tool + rate + force parameters + machine class -> cache key
//   -> <scene cache>/tune/KEY.toml (hit: instant) | tune::tune within --tune-budget-s (written
//   to the cache) | over budget: the defaults, said on stderr
//   -> the tool and the scene's sampler replaced by the choice; the choice and how it was made
//   go into SceneDescription::metadata ("tuning", "tuning_note": Stats, palp probe).
#pragma once

#include <string>
#include <vector>

#include "cli_common/cli.hpp"
#include "model/force_model.hpp"
#include "model/tool.hpp"
#include "scene/scene.hpp"

namespace palp::app {

inline const std::vector<std::string> kTuneAtStartFlags = {"tune"};
inline const std::vector<std::string> kTuneAtStartValued = {"tune-budget-s"};

inline constexpr const char* kTuneAtStartHelp =
    R"(  --tune                  at start, choose the cheapest tool points, gradient scheme and map
                          storage that feel as the most accurate (as palp tune; overrides
                          --scheme, --storage and the tool's point count), cached per scene,
                          tool, rate, parameters and machine in the scene cache (tune/): a
                          second start is instant; the choice is in Stats (palp probe)
  --tune-budget-s S       time --tune may take (60; 0.001..3600); over it palpd runs the
                          defaults (the tool as named, --scheme/--storage or theirs) and says so
)";

inline constexpr double kDefaultTuneBudgetS = 60.0;

struct StartTuning {
  std::string choice;  // "finger:19 analytic float32"; empty when the defaults run
  std::string note;    // for people: how it came ("tuned in 12.3 s", "cached", "over budget")
  bool cached = false;
};

// The cache file name (hex, no directory) of a tuning of the maps in prep_dir (their bytes are
// hashed) refined in memory to map_spacing_mm or not, for a tool, rate, parameters and machine
// class, and the tuner's default tolerance (with the version of how it is applied).
std::string tune_cache_key(const std::string& prep_dir, double map_spacing_mm,
                           const std::string& tool, double rate_hz, const ForceParams& params,
                           const std::string& machine);

// With --tune: replaces `tool` and, when the scheme or storage differ, scene.fields by the
// choice (from the cache, else measured within --tune-budget-s and cached); over budget, keeps
// them and says so on stderr. Without --tune: returns {} and changes nothing. UsageError for
// --tune with a replay device (a replay runs the recording's configuration) or a bad budget.
StartTuning tune_at_start(const cli::Args& args, Scene& scene, Tool& tool, const ForceParams& params,
                          double rate_hz, bool quiet);

}  // namespace palp::app
