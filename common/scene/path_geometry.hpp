// Internals shared by the trajectory generators: constants, helpers, the skin-search declarations.
//
// Not a public header: only surface_anchor.cpp, trajectory_gen.cpp and ribs_path.cpp include it.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>

#include "base/errors.hpp"
#include "base/vec.hpp"
#include "model/field_sampler.hpp"

namespace palp::path_geometry {

inline constexpr double kMaxRows = 1e8;          // refuse paths longer than this many rows
inline constexpr int kBisectionSteps = 60;       // skin search: interval / 2^60, far below 1 nm
inline constexpr int kDepthNewtonSteps = 6;      // pad-centre depth correction
inline constexpr double kNormalPatchHalf = 2.5;  // mm: the skin normal is averaged over +-2.5 mm
// The patch's half-size on a grid: kNormalPatchHalf, or two voxels where they are larger.
inline double patch_half_mm(const Grid& grid) {
  return std::max(kNormalPatchHalf, 2.0 * grid.max_spacing());
}
inline constexpr double kMinGradient = 1e-6;  // |grad D| below this: no direction

// --- Vectors ----------------------------------------------------------------------------------

inline Vec3d unit(const Vec3d& v) {
  const double n = norm(v);
  return n > 0.0 ? v * (1.0 / n) : Vec3d{};
}

inline Vec3d axis_vector(int axis, double sign) {
  Vec3d v{};
  (axis == 0 ? v.x : axis == 1 ? v.y : v.z) = sign;
  return v;
}

inline double component(const Vec3d& v, int axis) {
  return axis == 0 ? v.x : axis == 1 ? v.y : v.z;
}

inline void set_component(Vec3d& v, int axis, double value) {
  (axis == 0 ? v.x : axis == 1 ? v.y : v.z) = value;
}

// --- Options and rows -------------------------------------------------------------------------

inline void check_finite(double value, const char* what) {
  if (!std::isfinite(value)) throw UsageError(std::string(what) + " must be a finite number");
}

inline void check_non_negative(double value, const char* what) {
  if (!(std::isfinite(value) && value >= 0.0))
    throw UsageError(std::string(what) + " must be a finite number >= 0");
}

// Rows of a path of `duration` at `rate`: round(duration * rate) + 1.
inline std::size_t row_count(double duration_s, double rate_hz) {
  if (!(std::isfinite(rate_hz) && rate_hz > 0.0))
    throw UsageError("--rate must be a finite number > 0 (Hz)");
  check_non_negative(duration_s, "the path's duration");
  const double rows = std::round(duration_s * rate_hz) + 1.0;
  if (!(rows <= kMaxRows)) throw UsageError("the path would have more than 1e8 rows");
  return static_cast<std::size_t>(rows);
}

inline double row_time(std::size_t row, double rate_hz) {
  return static_cast<double>(row) / rate_hz;
}

// Linear ramp from a to b as t goes from 0 to duration: a before it starts, b once it is over
// (and for duration 0 from t = 0 on).
inline double ramp(double a, double b, double t, double duration) {
  if (t < 0.0) return a;
  if (!(duration > 0.0) || t >= duration) return b;
  return a + (b - a) * (t / duration);
}

// --- Skin search (surface_anchor.cpp) ---------------------------------------------------------

struct RayHit {
  bool found = false;
  double lambda = 0.0;
};

// The first crossing of D_surf from (D > 0) to (D <= 0) going from `origin` along `dir`
// (inside_first) or from (D <= 0) to (D > 0) (!inside_first), within max_lambda; bisected.
RayHit find_crossing(const FieldSampler& fields, const Vec3d& origin, const Vec3d& dir,
                     double max_lambda, double step, bool inside_first);

// Outward unit normal -grad D / |grad D| at x, or zero without a direction.
Vec3d outward_normal(const FieldSampler& fields, const Vec3d& x);

// The outward normal averaged over a patch of +-kNormalPatchHalf mm around the skin point.
Vec3d patch_normal(const FieldSampler& fields, const Vec3d& skin, const Vec3d& slide);

}  // namespace palp::path_geometry
