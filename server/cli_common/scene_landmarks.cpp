// A scene's prep directory and its landmarks: see scene_landmarks.hpp.
#include "cli_common/scene_landmarks.hpp"

#include <iostream>

#include "anatomy/landmark_detection.hpp"
#include "base/errors.hpp"
#include "scene/scene.hpp"

namespace palp::cli {

std::string scene_prep_dir(const std::string& scene, const PrepParams& params,
                           const std::string& cache_dir, bool quiet) {
  if (is_prep_directory(scene)) {
    if (!params.labels_path.empty())
      throw UsageError("--labels preps a CT input; " + scene + " is already a prep directory");
    return scene;
  }
  const std::string dir = scene_cache_path(scene, params, cache_dir);
  const PrepProgress progress = [quiet](const std::string& stage, bool finished, double) {
    if (!quiet && !finished) std::cerr << "  prep: " << stage << "\n";
  };
  const PrepResult r = run_prep(scene, dir, params, progress);
  if (!quiet) std::cerr << (r.from_cache ? "prep: from the cache " : "prep: into ") << dir << "\n";
  return dir;
}

anatomy::Landmarks find_landmarks_in(const std::string& prep_dir, const std::string& scene,
                                     bool quiet) {
  const anatomy::LandmarkInputs inputs = anatomy::read_landmark_inputs(prep_dir, scene);
  return anatomy::find_landmarks(inputs, [quiet](const std::string& step) {
    if (!quiet) std::cerr << "  landmarks: " << step << "\n";
  });
}

anatomy::Landmarks scene_landmarks(const std::string& scene, const std::string& cache_dir,
                                   bool quiet) {
  return find_landmarks_in(scene_prep_dir(scene, PrepParams{}, cache_dir, quiet), scene, quiet);
}

}  // namespace palp::cli
