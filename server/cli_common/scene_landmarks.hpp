// A scene's prep directory and the landmarks found in it, for the commands that take a SCENE:
// palp landmarks (which writes them), palp task and palpd --task (which find them when no
// --landmarks file is given).
#pragma once

#include <string>

#include "anatomy/landmarks.hpp"
#include "prep/prep.hpp"

namespace palp::cli {

// SCENE's prep directory: itself when it is one (UsageError with a label map: that preps a CT),
// else the cache entry under cache_dir the CT input or phantom is prepped into, once. Progress on
// stderr unless quiet.
std::string scene_prep_dir(const std::string& scene, const PrepParams& params,
                           const std::string& cache_dir, bool quiet);

// The landmarks anatomy::find_landmarks finds in the prep directory, with its progress on stderr
// unless quiet.
anatomy::Landmarks find_landmarks_in(const std::string& prep_dir, const std::string& scene,
                                     bool quiet);

// Both, for a scene prepped with default parameters.
anatomy::Landmarks scene_landmarks(const std::string& scene, const std::string& cache_dir,
                                   bool quiet);

}  // namespace palp::cli
