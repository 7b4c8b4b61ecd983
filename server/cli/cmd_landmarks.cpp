// palp landmarks SCENE --out FILE.json: the anatomical landmarks of a scan (spec "Files"), found
// by common/anatomy/landmark_detection.hpp, written as JSON, with a short summary.
//   SCENE -> prep directory (itself, or the cache entry a CT input is prepped into) -> masks and
//   d_surf -> find_landmarks -> write_landmarks
#include <chrono>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "anatomy/landmarks.hpp"
#include "cli/commands.hpp"
#include "cli_common/cli.hpp"
#include "cli_common/scene_landmarks.hpp"
#include "prep/prep.hpp"
#include "scene/scene.hpp"

namespace palp::cli {
namespace {

constexpr const char* kLandmarksUsage = R"(usage: palp landmarks SCENE --out FILE.json [options]

Finds the anatomical landmarks of a scan and writes them as JSON (spec "Files"; LPS mm, each
with a confidence, null with a reason where the scan cannot show one): the vertebrae named from
the sacrum up (L5..L1, then T12, the lowest rib-bearing vertebra) with body centre and
spinous-process tip, the ribs numbered by the vertebra their heads lie at, the intercostal
spaces at the mid-axillary line, the iliac crests' tops, Tuffier's line, the lumbar interspaces'
skin entry points and the femoral pulse points (docs/landmarks.md).
SCENE: a prep directory, a CT (.nii/.nii.gz/.mha/.mhd/.nrrd/.nhdr, DICOM directory) or
phantom:NAME; CTs are prepped once into the scene cache.
Options:
  --out FILE              the landmarks' JSON to write (required)
  --labels SEG            prep the CT with a lab's label map of it (TotalSegmentator, 3D Slicer):
                          its bone and arteries are used (not with a prep directory)
  --labels-map totalsegmentator  a label file that names no classes is TotalSegmentator's
  --cache-dir DIR         scene cache (default $PALP_SCENE_CACHE, else
                          $XDG_CACHE_HOME/palp/scenes, else ~/.cache/palp/scenes)
  -q, --quiet             print only errors
  -h, --help              show this help
)";

// The prep parameters --labels and --labels-map ask for.
PrepParams prep_params(const Args& args) {
  PrepParams params;
  if (const auto labels = args.get("labels")) {
    if (labels->empty()) throw UsageError("--labels needs a label map");
    params.labels_path = *labels;
  }
  if (const auto map = args.get("labels-map")) {
    if (params.labels_path.empty()) throw UsageError("--labels-map needs --labels SEG");
    params.labels_map = *map;
  }
  return params;
}

std::string summary(const anatomy::Landmarks& lm) {
  std::ostringstream out;
  int named = 0;
  std::string names;
  for (const auto& v : lm.vertebrae)
    if (v.name) ++named, names += (names.empty() ? "" : " ") + *v.name;
  out << "vertebrae  " << lm.vertebrae.size() << " found, " << named << " numbered"
      << (names.empty() ? "" : " (" + names + ")") << "\n";
  int ribs = 0;
  std::string rib_names;
  for (const auto& r : lm.ribs)
    if (r.number)
      ++ribs, rib_names += std::string(rib_names.empty() ? "" : " ") +
                           (r.side == anatomy::Side::right ? "R" : "L") + std::to_string(*r.number);
  out << "ribs       " << lm.ribs.size() << " found, " << ribs << " numbered"
      << (rib_names.empty() ? "" : " (" + rib_names + ")") << "\n";
  int spaces = 0, interspaces = 0, crests = 0, femoral = 0;
  for (const auto& s : lm.intercostal_spaces) spaces += s.skin_point.has_value();
  for (const auto& s : lm.lumbar_interspaces) interspaces += s.skin_point.has_value();
  for (const auto& c : lm.iliac_crests) crests += c.top.has_value();
  for (const auto& f : lm.femoral_pulse_points) femoral += f.skin_point.has_value();
  out << "intercostal spaces " << spaces << ", lumbar interspaces " << interspaces << " of "
      << lm.lumbar_interspaces.size() << ", iliac crests " << crests << ", femoral points "
      << femoral << "\n";
  if (lm.tuffier_line.z_mm)
    out << "Tuffier's line at z " << *lm.tuffier_line.z_mm << " mm"
        << (lm.tuffier_line.vertebral_level ? " (" + *lm.tuffier_line.vertebral_level + ")" : "")
        << "\n";
  for (const auto& note : lm.notes) out << "note: " << note << "\n";
  return out.str();
}

}  // namespace

int cmd_landmarks(const Arguments& argv) {
  const Args args(argv, {"help", "quiet"}, {"out", "labels", "labels-map", "cache-dir"});
  if (args.has("help")) {
    std::cout << kLandmarksUsage;
    return 0;
  }
  if (args.positional().size() != 1)
    throw UsageError("landmarks needs one SCENE (a prep directory, a CT or phantom:NAME)");
  const auto out = args.get("out");
  if (!out || out->empty()) throw UsageError("landmarks needs --out FILE.json");
  const bool quiet = args.has("quiet");
  const auto start = std::chrono::steady_clock::now();
  const std::string scene = args.positional().front();
  const std::string dir = scene_prep_dir(
      scene, prep_params(args), args.get("cache-dir").value_or(default_scene_cache_dir()), quiet);
  const anatomy::Landmarks lm = find_landmarks_in(dir, scene, quiet);
  anatomy::write_landmarks(*out, lm);
  if (!quiet) {
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << summary(lm) << "wrote " << *out << " in " << s << " s\n";
  }
  return 0;
}

}  // namespace palp::cli
