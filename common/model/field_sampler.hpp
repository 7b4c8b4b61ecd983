// Sampling the two distance maps (D_surf, D_bone) at scene points for the force loop.
//
// A point x (mm, scene frame: voxel (i,j,k) at (i*sx, j*sy, k*sz)) is sampled by trilinear
// interpolation between voxel centres, so the sampled domain is [0, (n-1)*s] along each axis.
// A point outside that box - beyond the grid, or in the outer half voxel where trilinear would
// need a neighbour that does not exist - is reported as not inside and, by the spec, counts as
// outside the body (no contact). NaN coordinates fail every comparison and land outside too.
//
// Two choices, fixed when the sampler is built, are axes of the speed-accuracy chart:
//   GradientScheme  AnalyticTrilinear  exact gradient of the trilinear interpolant (8 fetches)
//                   CentralDifference  (D(x + h e_a) - D(x - h e_a)) / 2h on the interpolant,
//                                      h = one voxel, one-sided at the grid edge (6 x 8 fetches)
//                   PrecomputedField   per-voxel central-difference gradient stored with the
//                                      map (one-sided at the edge), interpolated trilinearly
//   Storage         Float32            one float array per map (4 B/voxel/map)
//                   Int16              D = scale * q, q rounded and saturated to int16
//                                      (2 B/voxel/map; error <= scale/2, scale = max|D|/32767)
//                   Interleaved        one float record per voxel holding both maps (and, with
//                                      PrecomputedField, both gradients): [Ds, Db] or
//                                      [Ds, Db, gsx, gsy, gsz, gbx, gby, gbz], so the fetch that
//                                      serves the skin also brings the bone into cache.
// With Int16 a precomputed gradient is kept as float.
//
// The hot path is a template on (scheme, element type) chosen once per tick through
// FieldSampler::dispatch; nothing in it allocates, throws or calls through a pointer.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "base/vec.hpp"
#include "base/volume.hpp"

namespace palp {

enum class GradientScheme { AnalyticTrilinear, CentralDifference, PrecomputedField };
enum class Storage { Float32, Int16, Interleaved };

struct SamplerConfig {
  GradientScheme gradient = GradientScheme::AnalyticTrilinear;
  Storage storage = Storage::Float32;
};

// "analytic" | "central" | "precomputed" and "float32" | "int16" | "interleaved";
// UsageError for anything else.
GradientScheme parse_gradient_scheme(std::string_view name);
Storage parse_storage(std::string_view name);
const char* to_string(GradientScheme scheme);
const char* to_string(Storage storage);

// Value reported for points outside the sampled box (mm, far outside any body).
inline constexpr double kOutsideValue = -1.0e9;

struct FieldSample {
  double value = kOutsideValue;  // D(x), mm, positive inside
  Vec3d grad{};                  // grad D(x), mm/mm (zero outside)
  bool inside = false;           // x lies within the sampled box
};

namespace sampling {

// Grid geometry precomputed for the hot path.
struct Geometry {
  double origin[3] = {0.0, 0.0, 0.0};  // scene position of voxel (0,0,0) (a cropped map's offset)
  double inv_spacing[3] = {1.0, 1.0, 1.0};
  double spacing[3] = {1.0, 1.0, 1.0};
  double max_u[3] = {0.0, 0.0, 0.0};   // n - 1 (index units)
  std::int64_t max_i0[3] = {0, 0, 0};  // max(n - 2, 0): lower corner of the last cell
  std::size_t stride[3] = {1, 1, 1};   // linear index step of one voxel along an axis
  std::size_t step[3] = {0, 0, 0};     // neighbour step: stride, or 0 where n == 1
};

// The geometry of a grid (origin at the scene's 0; the caller places a cropped map's origin).
inline void set_grid(Geometry& g, const Grid& grid) {
  for (int a = 0; a < 3; ++a) {
    const std::int64_t n = grid.dims[a];
    g.spacing[a] = grid.spacing[a];
    g.inv_spacing[a] = 1.0 / grid.spacing[a];
    g.max_u[a] = static_cast<double>(n - 1);
    g.max_i0[a] = std::max<std::int64_t>(n - 2, 0);
  }
  g.stride[0] = 1;
  g.stride[1] = static_cast<std::size_t>(grid.dims[0]);
  g.stride[2] = static_cast<std::size_t>(grid.dims[0] * grid.dims[1]);
  for (int a = 0; a < 3; ++a) g.step[a] = grid.dims[a] > 1 ? g.stride[a] : 0;
}

// A map as laid out in memory: voxel v's value is scale * value[v * value_stride], and (with a
// precomputed gradient) its gradient component a is grad[v * grad_stride + a].
template <class T>
struct MapView {
  const T* value = nullptr;
  std::size_t value_stride = 1;
  double scale = 1.0;
  const float* grad = nullptr;
  std::size_t grad_stride = 3;
};

// The cell holding u (index units) and the fractions within it.
struct Cell {
  std::size_t base = 0;
  double t[3] = {0.0, 0.0, 0.0};
};

inline Cell cell_at(const Geometry& g, const double u[3]) {
  Cell c;
  for (int a = 0; a < 3; ++a) {
    const std::int64_t i = std::min(static_cast<std::int64_t>(u[a]), g.max_i0[a]);
    c.t[a] = u[a] - static_cast<double>(i);
    c.base += static_cast<std::size_t>(i) * g.stride[a];
  }
  return c;
}

// Corner values c[bit0 = +x, bit1 = +y, bit2 = +z], unscaled.
template <class T>
inline void corners(const Geometry& g, const MapView<T>& m, std::size_t base, double c[8]) {
  const std::size_t vs = m.value_stride;
  const std::size_t sx = g.step[0], sy = g.step[1], sz = g.step[2];
  c[0] = static_cast<double>(m.value[base * vs]);
  c[1] = static_cast<double>(m.value[(base + sx) * vs]);
  c[2] = static_cast<double>(m.value[(base + sy) * vs]);
  c[3] = static_cast<double>(m.value[(base + sx + sy) * vs]);
  c[4] = static_cast<double>(m.value[(base + sz) * vs]);
  c[5] = static_cast<double>(m.value[(base + sx + sz) * vs]);
  c[6] = static_cast<double>(m.value[(base + sy + sz) * vs]);
  c[7] = static_cast<double>(m.value[(base + sx + sy + sz) * vs]);
}

inline double trilinear(const double c[8], const double t[3]) {
  const double c00 = c[0] + (c[1] - c[0]) * t[0];
  const double c10 = c[2] + (c[3] - c[2]) * t[0];
  const double c01 = c[4] + (c[5] - c[4]) * t[0];
  const double c11 = c[6] + (c[7] - c[6]) * t[0];
  const double c0 = c00 + (c10 - c00) * t[1];
  const double c1 = c01 + (c11 - c01) * t[1];
  return c0 + (c1 - c0) * t[2];
}

inline bool in_box(const Geometry& g, const double u[3]) {
  // Written so that NaN fails.
  return u[0] >= 0.0 && u[0] <= g.max_u[0] && u[1] >= 0.0 && u[1] <= g.max_u[1] && u[2] >= 0.0 &&
         u[2] <= g.max_u[2];
}

// Interpolated value at u (index units, inside the box), in mm.
template <class T>
inline double value_at_u(const Geometry& g, const MapView<T>& m, const double u[3]) {
  const Cell cell = cell_at(g, u);
  double c[8];
  corners(g, m, cell.base, c);
  return m.scale * trilinear(c, cell.t);
}

// Interpolated value at x (mm) alone, kOutsideValue outside the box.
template <class T>
inline double value(const Geometry& g, const MapView<T>& m, const Vec3d& x) {
  const double u[3] = {(x.x - g.origin[0]) * g.inv_spacing[0], (x.y - g.origin[1]) * g.inv_spacing[1],
                       (x.z - g.origin[2]) * g.inv_spacing[2]};
  return in_box(g, u) ? value_at_u(g, m, u) : kOutsideValue;
}

template <GradientScheme G, class T>
inline FieldSample sample(const Geometry& g, const MapView<T>& m, const Vec3d& x) {
  FieldSample out;
  const double u[3] = {(x.x - g.origin[0]) * g.inv_spacing[0], (x.y - g.origin[1]) * g.inv_spacing[1],
                       (x.z - g.origin[2]) * g.inv_spacing[2]};
  if (!in_box(g, u)) return out;
  out.inside = true;
  const Cell cell = cell_at(g, u);
  double c[8];
  corners(g, m, cell.base, c);
  const double* t = cell.t;
  if constexpr (G == GradientScheme::AnalyticTrilinear) {
    // Value and the exact partial derivatives of the same interpolant.
    const double c00 = c[0] + (c[1] - c[0]) * t[0];
    const double c10 = c[2] + (c[3] - c[2]) * t[0];
    const double c01 = c[4] + (c[5] - c[4]) * t[0];
    const double c11 = c[6] + (c[7] - c[6]) * t[0];
    const double c0 = c00 + (c10 - c00) * t[1];
    const double c1 = c01 + (c11 - c01) * t[1];
    out.value = m.scale * (c0 + (c1 - c0) * t[2]);
    const double dx0 = (c[1] - c[0]) + ((c[3] - c[2]) - (c[1] - c[0])) * t[1];
    const double dx1 = (c[5] - c[4]) + ((c[7] - c[6]) - (c[5] - c[4])) * t[1];
    const double dy = (c10 - c00) + ((c11 - c01) - (c10 - c00)) * t[2];
    out.grad = {m.scale * (dx0 + (dx1 - dx0) * t[2]) * g.inv_spacing[0],
                m.scale * dy * g.inv_spacing[1], m.scale * (c1 - c0) * g.inv_spacing[2]};
  } else if constexpr (G == GradientScheme::CentralDifference) {
    out.value = m.scale * trilinear(c, t);
    double grad[3];
    for (int a = 0; a < 3; ++a) {
      double up[3] = {u[0], u[1], u[2]};
      double dn[3] = {u[0], u[1], u[2]};
      up[a] = std::min(u[a] + 1.0, g.max_u[a]);
      dn[a] = std::max(u[a] - 1.0, 0.0);
      const double span = (up[a] - dn[a]) * g.spacing[a];
      grad[a] = span > 0.0 ? (value_at_u(g, m, up) - value_at_u(g, m, dn)) / span : 0.0;
    }
    out.grad = {grad[0], grad[1], grad[2]};
  } else {
    out.value = m.scale * trilinear(c, t);
    const std::size_t sx = g.step[0], sy = g.step[1], sz = g.step[2];
    const std::size_t b = cell.base;
    const std::size_t v[8] = {b,      b + sx,      b + sy,      b + sx + sy,
                              b + sz, b + sx + sz, b + sy + sz, b + sx + sy + sz};
    double grad[3];
    for (int a = 0; a < 3; ++a) {
      double gc[8];
      for (int k = 0; k < 8; ++k) gc[k] = static_cast<double>(m.grad[v[k] * m.grad_stride + a]);
      grad[a] = trilinear(gc, t);
    }
    out.grad = {grad[0], grad[1], grad[2]};
  }
  return out;
}

// Both maps at x from Interleaved records with precomputed gradients, [Ds, Db, gsx, gsy, gsz,
// gbx, gby, gbz] per voxel: one cell and one pass over its 8 corners for the 8 channels, each
// interpolated as trilinear() does, so the result equals sample<PrecomputedField> of each map
// bit for bit (the channels are independent lanes a compiler may vectorise).
inline constexpr std::size_t kPairRecord = 8;
inline void sample_pair(const Geometry& g, const float* records, const Vec3d& x, FieldSample& surf,
                        FieldSample& bone) {
  const double u[3] = {(x.x - g.origin[0]) * g.inv_spacing[0], (x.y - g.origin[1]) * g.inv_spacing[1],
                       (x.z - g.origin[2]) * g.inv_spacing[2]};
  if (!in_box(g, u)) {
    surf = FieldSample{};
    bone = FieldSample{};
    return;
  }
  const Cell cell = cell_at(g, u);
  const std::size_t sx = g.step[0], sy = g.step[1], sz = g.step[2];
  const std::size_t b = cell.base;
  const float* corner[8] = {records + b * kPairRecord,
                            records + (b + sx) * kPairRecord,
                            records + (b + sy) * kPairRecord,
                            records + (b + sx + sy) * kPairRecord,
                            records + (b + sz) * kPairRecord,
                            records + (b + sx + sz) * kPairRecord,
                            records + (b + sy + sz) * kPairRecord,
                            records + (b + sx + sy + sz) * kPairRecord};
  double r[kPairRecord];
  for (std::size_t ch = 0; ch < kPairRecord; ++ch) {
    double c[8];
    for (int k = 0; k < 8; ++k) c[k] = static_cast<double>(corner[k][ch]);
    r[ch] = trilinear(c, cell.t);
  }
  surf.inside = bone.inside = true;
  surf.value = r[0];  // (a float map's scale is 1)
  bone.value = r[1];
  surf.grad = {r[2], r[3], r[4]};
  bone.grad = {r[5], r[6], r[7]};
}

}  // namespace sampling

// What the tick sees: both maps behind one compile-time scheme and element type.
template <GradientScheme G, class T>
struct FieldAccess {
  const sampling::Geometry* geometry = nullptr;
  sampling::MapView<T> surf, bone;
  bool has_bone = false;
  // The bone-beneath map (model/bone_beneath.hpp) once prepared, else value == nullptr.
  sampling::MapView<float> beneath;

  // Interleaved records with precomputed gradients (sampling::sample_pair), else nullptr.
  const float* pair_records = nullptr;

  FieldSample surf_at(const Vec3d& x) const { return sampling::sample<G>(*geometry, surf, x); }
  FieldSample bone_at(const Vec3d& x) const { return sampling::sample<G>(*geometry, bone, x); }
  // Both at x: one pass over the cell where the records allow it, else one sample of each.
  void surf_and_bone_at(const Vec3d& x, FieldSample& s, FieldSample& b) const {
    if (pair_records != nullptr) {
      sampling::sample_pair(*geometry, pair_records, x, s, b);
    } else {
      s = surf_at(x);
      b = bone_at(x);
    }
  }
  // D_bone(x) without its gradient (8 fetches), kOutsideValue outside the box.
  double bone_value_at(const Vec3d& x) const { return sampling::value(*geometry, bone, x); }
  // Distance along the skin's inward normal to bone (mm), kOutsideValue outside the box.
  double beneath_at(const Vec3d& x) const { return sampling::value(*geometry, beneath, x); }
};

// The distance maps in the chosen storage. Built once (may take seconds and memory); constant
// afterwards and safe to share between threads and models.
class FieldSampler {
 public:
  // Takes the maps by value: with Float32 storage the arrays are moved in without a copy
  // (std::move them in if the caller no longer needs them). The grids must agree in dimensions
  // and spacing (UsageError); values must be finite (InputError); memory is checked before each
  // allocation (ResourceError).
  FieldSampler(DistanceMap surf, DistanceMap bone, SamplerConfig config = {});
  // Maps that are a window of a scene (model/map_window.hpp): voxel (0,0,0) lies at `origin`
  // in the scene frame; points outside the window sample as outside the grid.
  FieldSampler(DistanceMap surf, DistanceMap bone, SamplerConfig config, const Vec3d& origin);
  // No bone map: the bone terms of the force model are skipped.
  explicit FieldSampler(DistanceMap surf, SamplerConfig config = {});

  const Grid& grid() const { return grid_; }
  // Scene position of voxel (0,0,0): zero unless the maps are a window.
  Vec3d origin() const { return {geometry_.origin[0], geometry_.origin[1], geometry_.origin[2]}; }
  const SamplerConfig& config() const { return config_; }
  bool has_bone() const { return has_bone_; }
  // Quantisation step (mm) of each map with Int16 storage; 0 otherwise.
  double surf_quantum() const { return config_.storage == Storage::Int16 ? surf_scale_ : 0.0; }
  double bone_quantum() const { return config_.storage == Storage::Int16 ? bone_scale_ : 0.0; }
  // Bytes the sampler holds per voxel (both maps and any gradient field).
  std::size_t bytes_per_voxel() const;

  // Calls f(FieldAccess<G, T>) for the configured scheme and storage and returns its result.
  template <class F>
  decltype(auto) dispatch(F&& f) const {
    switch (config_.storage) {
      case Storage::Int16:
        return dispatch_scheme<std::int16_t>(f);
      case Storage::Float32:
      case Storage::Interleaved:
        break;
    }
    return dispatch_scheme<float>(f);
  }

  // Convenience (tests, tools): one sample, dispatched per call.
  FieldSample sample_surf(const Vec3d& x) const;
  FieldSample sample_bone(const Vec3d& x) const;
  // D_bone(x) alone (kOutsideValue outside the box or without a bone map).
  double bone_value(const Vec3d& x) const;

  // palp's bone-beneath map (model/bone_beneath.hpp): traced on the first call (a fraction of a
  // second for a CT, 4 B/voxel more), at once afterwards; safe from several threads. Ticks see
  // it (FieldAccess::beneath) only after it is prepared. No-op without a bone map.
  void prepare_bone_beneath() const;
  // Takes a bone-beneath map traced elsewhere (a window of a whole scene's: map_window.hpp)
  // instead of tracing one; UsageError for a wrong size or one already prepared.
  void adopt_bone_beneath(std::vector<float> map) const;
  bool has_bone_beneath() const;
  // The prepared map, nullptr before (tests, tools).
  const float* bone_beneath_data() const;

 private:
  void build(DistanceMap& surf, DistanceMap* bone);

  template <class T>
  sampling::MapView<T> view(bool bone) const {
    sampling::MapView<T> v;
    if constexpr (std::is_same_v<T, std::int16_t>) {
      v.value = bone ? bone_i16_.data() : surf_i16_.data();
      v.scale = bone ? bone_scale_ : surf_scale_;
      v.grad = bone ? bone_grad_.data() : surf_grad_.data();
    } else if (config_.storage == Storage::Interleaved) {
      v.value = interleaved_.data() + (bone ? 1 : 0);
      v.value_stride = record_;
      v.grad = record_ > 2 ? interleaved_.data() + (bone ? 5 : 2) : nullptr;
      v.grad_stride = record_;
    } else {
      v.value = bone ? bone_f32_.data() : surf_f32_.data();
      v.grad = bone ? bone_grad_.data() : surf_grad_.data();
    }
    return v;
  }

  template <class T, class F>
  decltype(auto) dispatch_scheme(F& f) const {
    switch (config_.gradient) {
      case GradientScheme::CentralDifference:
        return f(access<GradientScheme::CentralDifference, T>());
      case GradientScheme::PrecomputedField:
        return f(access<GradientScheme::PrecomputedField, T>());
      case GradientScheme::AnalyticTrilinear:
        break;
    }
    return f(access<GradientScheme::AnalyticTrilinear, T>());
  }

  template <GradientScheme G, class T>
  FieldAccess<G, T> access() const {
    FieldAccess<G, T> a;
    a.geometry = &geometry_;
    a.surf = view<T>(false);
    a.bone = view<T>(true);
    a.has_bone = has_bone_;
    a.beneath.value = bone_beneath_data();
    if constexpr (G == GradientScheme::PrecomputedField && std::is_same_v<T, float>) {
      if (config_.storage == Storage::Interleaved && record_ == sampling::kPairRecord)
        a.pair_records = interleaved_.data();
    }
    return a;
  }

  Grid grid_;
  SamplerConfig config_;
  sampling::Geometry geometry_;
  bool has_bone_ = false;
  std::vector<float> surf_f32_, bone_f32_;         // Float32
  std::vector<std::int16_t> surf_i16_, bone_i16_;  // Int16
  double surf_scale_ = 1.0, bone_scale_ = 1.0;     // Int16 quantum (mm)
  std::vector<float> interleaved_;                 // Interleaved records
  std::size_t record_ = 0;                         // floats per Interleaved record
  std::vector<float> surf_grad_, bone_grad_;       // PrecomputedField with Float32 / Int16
  // Built lazily, once (a unique_ptr so the sampler stays movable).
  struct Beneath {
    std::once_flag once;
    std::vector<float> map;
    std::atomic<const float*> ready{nullptr};
  };
  std::unique_ptr<Beneath> beneath_ = std::make_unique<Beneath>();
};

}  // namespace palp
