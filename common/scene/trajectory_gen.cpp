// The flat paths of trajectory_gen.hpp: slide_ramp, slide_speed, press_hold and their validate.
//
// Data flow of every path (here and in ribs_path.cpp):
//   time t (row i / rate) -> phase (press, slide, hold, ...) -> lateral offset and depth
//   -> pad centre on the skin frame -> device pose (pad centre + pad_offset along the normal).
// The skin search and the anchors are in surface_anchor.cpp, the helpers shared by the three
// files in path_geometry.hpp.
#include "scene/trajectory_gen.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "base/errors.hpp"
#include "scene/path_geometry.hpp"

namespace palp {

using namespace path_geometry;

namespace {

// A pose on the anchor's plane: lateral offsets (along slide, along x_tool) and depth.
struct FlatFrame {
  SurfaceAnchor anchor;
  Vec3d across{};  // x_tool = slide × normal
  Quat orientation{};
  double pad_offset = 0.0;

  Pose at(double along_slide, double along_across, double depth) const {
    const Vec3d centre =
        anchor.point + along_slide * anchor.slide + along_across * across - depth * anchor.normal;
    return pad_pose(centre, anchor.normal, orientation, pad_offset);
  }
};

FlatFrame flat_frame(const SurfaceAnchor& anchor, double pad_offset) {
  FlatFrame f;
  f.anchor.point = anchor.point;
  f.anchor.normal = unit(anchor.normal);
  if (!(norm(f.anchor.normal) > 0.5) || !is_finite(anchor.point))
    throw UsageError("surface anchor needs a finite point and a non-zero normal");
  f.orientation = surface_orientation(f.anchor.normal, anchor.slide);
  f.anchor.slide = rotate(f.orientation, Vec3d{0.0, 1.0, 0.0});
  f.across = rotate(f.orientation, Vec3d{1.0, 0.0, 0.0});
  f.pad_offset = pad_offset;
  return f;
}

// Distance covered after tau seconds of piecewise-constant speeds, segment_s each.
double piecewise_distance(const std::vector<double>& speeds, double segment_s, double tau) {
  double distance = 0.0;
  for (double speed : speeds) {
    const double dt = std::clamp(tau, 0.0, segment_s);
    distance += speed * dt;
    tau -= segment_s;
  }
  return distance;
}

// splitmix64: a deterministic stream for the jitter.
std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Uniform in [-1, 1) from (seed, row, axis).
double jitter_unit(std::uint64_t seed, std::size_t row, int axis) {
  const std::uint64_t h = splitmix64(
      seed ^ splitmix64(2 * static_cast<std::uint64_t>(row) + static_cast<std::uint64_t>(axis)));
  return static_cast<double>(h >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

}  // namespace

void validate(const SlideRampSpec& spec) {
  check_finite(spec.speed_mm_s, "--speed");
  check_finite(spec.depth_start_mm, "--depth-start");
  check_finite(spec.depth_end_mm, "--depth");
  row_count(spec.duration_s, spec.rate_hz);
}

void validate(const SlideSpeedSpec& spec) {
  check_finite(spec.depth_mm, "--depth");
  check_non_negative(spec.press_s, "--press-time");
  check_non_negative(spec.segment_s, "--segment");
  check_non_negative(spec.hold_s, "--hold");
  if (spec.speeds_mm_s.empty()) throw UsageError("--speeds needs at least one speed");
  for (double v : spec.speeds_mm_s) check_finite(v, "each of --speeds");
  row_count(
      spec.press_s + spec.segment_s * static_cast<double>(spec.speeds_mm_s.size()) + spec.hold_s,
      spec.rate_hz);
}

void validate(const PressHoldSpec& spec) {
  check_finite(spec.approach_mm, "--approach");
  check_finite(spec.depth_mm, "--depth");
  check_finite(spec.shift_mm, "--shift");
  check_non_negative(spec.press_s, "--press-time");
  check_non_negative(spec.shift_s, "--shift-time");
  check_non_negative(spec.hold_s, "--hold");
  check_non_negative(spec.jitter_mm, "--jitter");
  row_count(spec.press_s + spec.shift_s + spec.hold_s, spec.rate_hz);
}

Trajectory slide_ramp(const SurfaceAnchor& anchor, double pad_offset, const SlideRampSpec& spec) {
  validate(spec);
  const std::size_t rows = row_count(spec.duration_s, spec.rate_hz);
  const FlatFrame frame = flat_frame(anchor, pad_offset);
  const double travel = spec.speed_mm_s * spec.duration_s;
  Trajectory out(rows);
  for (std::size_t i = 0; i < rows; ++i) {
    // t -> lateral offset (constant speed, centred) and depth (linear ramp) -> pose.
    const double t = row_time(i, spec.rate_hz);
    const double along = -0.5 * travel + spec.speed_mm_s * t;
    const double depth = ramp(spec.depth_start_mm, spec.depth_end_mm, t, spec.duration_s);
    out[i] = {t, frame.at(along, 0.0, depth)};
  }
  return out;
}

Trajectory slide_speed(const SurfaceAnchor& anchor, double pad_offset, const SlideSpeedSpec& spec) {
  validate(spec);
  const double slide_s = spec.segment_s * static_cast<double>(spec.speeds_mm_s.size());
  const double duration = spec.press_s + slide_s + spec.hold_s;
  const std::size_t rows = row_count(duration, spec.rate_hz);
  const FlatFrame frame = flat_frame(anchor, pad_offset);
  const double travel = piecewise_distance(spec.speeds_mm_s, spec.segment_s, slide_s);
  Trajectory out(rows);
  for (std::size_t i = 0; i < rows; ++i) {
    // t -> press at rest, slide at the segment's speed, hold at rest -> pose.
    const double t = row_time(i, spec.rate_hz);
    const double depth = ramp(0.0, spec.depth_mm, t, spec.press_s);
    const double moved = piecewise_distance(spec.speeds_mm_s, spec.segment_s, t - spec.press_s);
    out[i] = {t, frame.at(-0.5 * travel + moved, 0.0, depth)};
  }
  return out;
}

Trajectory press_hold(const SurfaceAnchor& anchor, double pad_offset, const PressHoldSpec& spec) {
  validate(spec);
  const double hold_start = spec.press_s + spec.shift_s;
  const std::size_t rows = row_count(hold_start + spec.hold_s, spec.rate_hz);
  const FlatFrame frame = flat_frame(anchor, pad_offset);
  Trajectory out(rows);
  for (std::size_t i = 0; i < rows; ++i) {
    // t -> press (depth ramp), shift (lateral ramp), hold (+ jitter on both tangents) -> pose.
    const double t = row_time(i, spec.rate_hz);
    const double depth = ramp(-spec.approach_mm, spec.depth_mm, t, spec.press_s);
    double along = ramp(0.0, spec.shift_mm, t - spec.press_s, spec.shift_s);
    double across = 0.0;
    if (t > hold_start && spec.jitter_mm > 0.0) {
      along += spec.jitter_mm * jitter_unit(spec.seed, i, 0);
      across += spec.jitter_mm * jitter_unit(spec.seed, i, 1);
    }
    out[i] = {t, frame.at(along, across, depth)};
  }
  return out;
}

}  // namespace palp
