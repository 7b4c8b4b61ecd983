// Masks in the patient's axis order and the skin's distance at world points (patient_volume.hpp).
#include "anatomy/patient_volume.hpp"

#include <algorithm>
#include <cmath>

#include "base/errors.hpp"
#include "base/patient_frame.hpp"

namespace palp::anatomy {
namespace {

// Source index (fractional) of a patient index.
Vec3 source_index(const PatientMask& m, const Vec3d& p) {
  const double v[3] = {p.x, p.y, p.z};
  Vec3 s{0.0, 0.0, 0.0};
  for (int a = 0; a < 3; ++a) {
    const int axis = m.axis_of[a];
    const double n = static_cast<double>(m.source.dims[axis]);
    s[axis] = m.sign[a] > 0 ? v[a] : n - 1.0 - v[a];
  }
  return s;
}

void fill(PatientMask& out, const Mask& mask, bool keep_values = false) {
  out.data.assign(static_cast<std::size_t>(out.dims[0] * out.dims[1] * out.dims[2]), 0);
  for (std::int64_t z = 0; z < out.dims[2]; ++z)
    for (std::int64_t y = 0; y < out.dims[1]; ++y)
      for (std::int64_t x = 0; x < out.dims[0]; ++x) {
        const std::int64_t p[3] = {x, y, z};
        std::int64_t s[3] = {0, 0, 0};
        for (int a = 0; a < 3; ++a) {
          const int axis = out.axis_of[a];
          s[axis] = out.sign[a] > 0 ? p[a] : mask.grid.dims[axis] - 1 - p[a];
        }
        const std::uint8_t v = mask.at(s[0], s[1], s[2]);
        out.data[out.linear(x, y, z)] = keep_values ? v : static_cast<std::uint8_t>(v != 0);
      }
}

}  // namespace

Vec3d PatientMask::world(const Vec3d& index) const {
  const Vec3 s = source_index(*this, index);
  return world_of_scene(
      source, {s[0] * source.spacing[0], s[1] * source.spacing[1], s[2] * source.spacing[2]});
}

Vec3d PatientMask::index_of(const Vec3d& world_mm) const {
  const Vec3d scene = scene_of_world(source, world_mm);
  const double s[3] = {scene.x / source.spacing[0], scene.y / source.spacing[1],
                       scene.z / source.spacing[2]};
  double p[3] = {0.0, 0.0, 0.0};
  for (int a = 0; a < 3; ++a) {
    const int axis = axis_of[a];
    const double n = static_cast<double>(source.dims[axis]);
    p[a] = sign[a] > 0 ? s[axis] : n - 1.0 - s[axis];
  }
  return {p[0], p[1], p[2]};
}

PatientMask to_patient_order(const Mask& mask) {
  PatientMask out;
  out.source = mask.grid;
  const PatientFrame frame = patient_frame(mask.grid);
  const Anatomy toward[3] = {Anatomy::Left, Anatomy::Posterior, Anatomy::Superior};
  std::array<bool, 3> used{false, false, false};
  for (int a = 0; a < 3; ++a) {
    const SignedAxis s = frame.nearest_axis(toward[a]);
    if (used[s.axis]) throw InputError("the scan's direction matrix maps two axes onto one");
    used[s.axis] = true;
    out.axis_of[a] = s.axis;
    out.sign[a] = s.sign;
    out.dims[a] = mask.grid.dims[s.axis];
    out.spacing[a] = mask.grid.spacing[s.axis];
  }
  fill(out, mask);
  return out;
}

PatientMask to_patient_order_like(const Mask& mask, const PatientMask& like, bool keep_values) {
  if (mask.grid.dims != like.source.dims)
    throw InputError("a mask of the scene is not on the bone mask's grid");
  PatientMask out = like;
  fill(out, mask, keep_values);
  return out;
}

std::vector<SliceBody> slice_bodies(const PatientMask& body) {
  std::vector<SliceBody> out(static_cast<std::size_t>(body.dims[2]));
  for (std::int64_t z = 0; z < body.dims[2]; ++z) {
    SliceBody& s = out[static_cast<std::size_t>(z)];
    double sx = 0.0, sy = 0.0;
    s.y_front = static_cast<double>(body.dims[1]);
    s.y_back = -1.0;
    for (std::int64_t y = 0; y < body.dims[1]; ++y)
      for (std::int64_t x = 0; x < body.dims[0]; ++x) {
        if (!body.data[body.linear(x, y, z)]) continue;
        ++s.voxels;
        sx += static_cast<double>(x), sy += static_cast<double>(y);
        s.y_front = std::min(s.y_front, static_cast<double>(y));
        s.y_back = std::max(s.y_back, static_cast<double>(y));
      }
    if (s.voxels)
      s.cx = sx / static_cast<double>(s.voxels), s.cy = sy / static_cast<double>(s.voxels);
  }
  return out;
}

double SkinMap::distance(const Vec3d& world_mm) const {
  const Grid& g = map_.grid;
  const Vec3d scene = scene_of_world(g, world_mm);
  const double f[3] = {scene.x / g.spacing[0], scene.y / g.spacing[1], scene.z / g.spacing[2]};
  std::int64_t i0[3];
  double t[3];
  for (int a = 0; a < 3; ++a) {
    const double c = std::clamp(f[a], 0.0, static_cast<double>(g.dims[a] - 1));
    i0[a] = std::min<std::int64_t>(static_cast<std::int64_t>(std::floor(c)), g.dims[a] - 2);
    i0[a] = std::max<std::int64_t>(i0[a], 0);
    t[a] = g.dims[a] > 1 ? c - static_cast<double>(i0[a]) : 0.0;
  }
  double sum = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    double w = 1.0;
    std::int64_t idx[3];
    for (int a = 0; a < 3; ++a) {
      const int bit = (corner >> a) & 1;
      idx[a] = std::min<std::int64_t>(i0[a] + bit, g.dims[a] - 1);
      w *= bit ? t[a] : 1.0 - t[a];
    }
    if (w > 0.0) sum += w * static_cast<double>(map_.at(idx[0], idx[1], idx[2]));
  }
  return sum;
}

std::optional<Vec3d> SkinMap::outward_normal(const Vec3d& p) const {
  const double h = 0.5 * map_.grid.min_spacing();
  const Vec3d g{distance(p + Vec3d{h, 0, 0}) - distance(p - Vec3d{h, 0, 0}),
                distance(p + Vec3d{0, h, 0}) - distance(p - Vec3d{0, h, 0}),
                distance(p + Vec3d{0, 0, h}) - distance(p - Vec3d{0, 0, h})};
  const double n = norm(g);
  if (!(n > 1e-9)) return std::nullopt;
  return g * (-1.0 / n);
}

std::optional<Vec3d> SkinMap::project(const Vec3d& start, const Vec3d& direction,
                                      double max_mm) const {
  if (empty()) return std::nullopt;
  const double step = 0.5 * map_.grid.min_spacing();
  const bool inside = distance(start) > 0.0;
  double a = 0.0;
  for (double s = step; s <= max_mm + 1e-9; s += step) {
    if ((distance(start + direction * s) > 0.0) != inside) {
      double lo = a, hi = s;
      while (hi - lo > 0.01) {
        const double mid = 0.5 * (lo + hi);
        ((distance(start + direction * mid) > 0.0) == inside ? lo : hi) = mid;
      }
      return start + direction * (0.5 * (lo + hi));
    }
    a = s;
  }
  return std::nullopt;
}

}  // namespace palp::anatomy
