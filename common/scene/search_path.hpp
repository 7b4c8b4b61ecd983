// A scripted trainee searching for a training task's target (docs/tasks.md): the `search` kind
// of palp traj. A deterministic pure function of the scene, the target and the spec.
//
// One trial per entry of `misses_mm`, one after another on the same clock:
//   approach  the pad from `approach_mm` above the skin to `depth_mm` below it, straight along
//             the start point's inward normal, at rest (`press_s`); the start point is on the
//             skin `start_mm` from the target toward the patient's superior (negative: inferior)
//   slide     at `depth_mm`, over the skin at `speed_mm_s` to the end point: the target moved
//             `miss` mm toward superior along the skin (0: the target itself; a trainee who
//             marks the space or the rib above misses by one rib's pitch or half of it)
//   hold      at rest (`hold_s`); the trial's mark is at the hold's middle
//   lift      back to `approach_mm` above the skin (`press_s`)
//   transfer  (between trials) through the air at `approach_mm` above the skin to the next
//             start, at `speed_mm_s`
// "Along the skin" is a walk on the scene's skin (D_surf = 0) in steps of kSearchStepMm, each
// toward the patient's superior projected onto the skin's tangent plane, then back onto the
// skin along the normal; the pad follows it at D_surf = depth (pad_centre_at_depth), the tool's
// +z along the local outward normal averaged over a patch (patch_normal), +y toward superior.
#pragma once

#include <string>
#include <vector>

#include "base/vec.hpp"
#include "model/field_sampler.hpp"
#include "scene/trajectory.hpp"

namespace palp {

// The target in the patient's LPS world frame (training::TaskTarget's point and normal, as the
// landmarks give them); converted to the scene frame with the grid's placement.
struct SearchTarget {
  Vec3d point_lps{};
  Vec3d normal_lps{};  // outward unit normal
};

struct SearchSpec {
  double rate_hz = 1000.0;
  double start_mm = 25.0;              // along the skin from the target, + = superior
  std::vector<double> misses_mm{0.0};  // one trial each; + = superior of the target
  double depth_mm = 4.0;               // the pad's depth during the slide and the hold
  double approach_mm = 10.0;           // above the skin at the start of the approach
  double press_s = 1.0;                // the approach, and the lift
  double speed_mm_s = 10.0;            // the slide and the transfer
  double hold_s = 1.0;
};
void validate(const SearchSpec& spec);  // UsageError naming the option

// Walk steps along the skin, mm.
inline constexpr double kSearchStepMm = 0.5;
// The longest walk from the target (start or miss), mm.
inline constexpr double kSearchMaxWalkMm = 200.0;
// At most this many trials in one run.
inline constexpr std::size_t kSearchMaxTrials = 100;

struct SearchPath {
  Trajectory trajectory;
  std::vector<double> mark_times_s;     // one per trial, at its hold's middle
  Vec3d target_scene{};                 // the target projected onto the scene's skin
  std::vector<Vec3d> end_points_scene;  // each trial's end point on the skin
};

// InputError when the target does not lie near skin in this scene (the landmarks of another
// scan), or the walk leaves the body or the grid.
SearchPath search_path(const FieldSampler& fields, const SearchTarget& target, double pad_offset,
                       const SearchSpec& spec);

}  // namespace palp
