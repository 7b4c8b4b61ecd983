// Finding the anatomical landmarks of one scan (landmarks.hpp's data) in a prepped scene: the
// vertebral column split into vertebrae and numbered from the sacrum, the ribs numbered by the
// vertebra their heads lie at, the intercostal spaces at the mid-axillary line, the iliac crests
// and Tuffier's line, the lumbar interspaces on the posterior midline and the femoral pulse
// points. Methods, confidences and what each needs of the scan: docs/landmarks.md.
//
// Data flow: prep directory (bone, body, d_surf; artery or vessel when present) -> masks in the
// patient's axis order (patient_volume.hpp) -> spine (spine_levels.hpp) -> ribs (ribs.hpp) ->
// pelvis (pelvis.hpp) -> skin points and normals from d_surf -> Landmarks in LPS world mm.
#pragma once

#include <functional>
#include <optional>
#include <string>

#include "anatomy/landmarks.hpp"
#include "base/volume.hpp"

namespace palp::anatomy {

// What find_landmarks reads. bone and body: prep's masks on one grid; d_surf: the skin's signed
// distance (mm, positive inside) on that grid or its refinement; artery: a mask of arteries on
// the masks' grid (dims 0 when the scene has none).
struct LandmarkInputs {
  std::string scene;
  Mask bone;
  Mask body;
  DistanceMap d_surf;
  Mask artery;
  std::string artery_source;  // "artery.nii.gz", "vessel.nii.gz (arterial phase)", ...
  // prep --labels' labelled vertebrae and ribs (prep.hpp, kSkeletonLabelsFile): value v is
  // skeleton_names[v - 1] ("vertebrae_L3", "sacrum", "rib_left_9"); empty without.
  Mask skeleton_labels;
  std::vector<std::string> skeleton_names;
};

// Reports a step starting ("spine", "ribs", ...), for a command's progress line.
using LandmarkProgress = std::function<void(const std::string& step)>;

Landmarks find_landmarks(const LandmarkInputs& inputs, const LandmarkProgress& progress = {});

// The inputs of a prep directory: bone.nii.gz, body.nii.gz, d_surf.nii.gz, and as the artery
// artery.nii.gz, else vessel.nii.gz when prep.json's contrast_phase is "arterial". InputError
// naming the file when one of the three it needs is missing or unreadable.
LandmarkInputs read_landmark_inputs(const std::string& prep_dir, const std::string& scene);

}  // namespace palp::anatomy
