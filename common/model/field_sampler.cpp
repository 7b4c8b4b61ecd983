#include "model/field_sampler.hpp"

#include <cmath>
#include <limits>
#include <sstream>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "model/bone_beneath.hpp"

namespace palp {
namespace {

// Per-voxel gradient by central differences on the voxel grid (one-sided at the edges, zero
// along an axis of one voxel), written as out[v * stride + offset + axis].
void gradient_field(const Grid& g, const std::vector<float>& d, float* out, std::size_t stride,
                    std::size_t offset) {
  const std::int64_t n[3] = {g.dims[0], g.dims[1], g.dims[2]};
  const std::size_t step[3] = {1, static_cast<std::size_t>(n[0]),
                               static_cast<std::size_t>(n[0] * n[1])};
  // Slices in parallel: every voxel's gradient depends only on the map (a refined CT's maps hold
  // 10^7 voxels, prep/maps/map_refine.hpp).
  parallel_for_chunks(n[2], 1, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t k = k0; k < k1; ++k)
      for (std::int64_t j = 0; j < n[1]; ++j)
        for (std::int64_t i = 0; i < n[0]; ++i) {
          const std::size_t v = g.linear(i, j, k);
          const std::int64_t idx[3] = {i, j, k};
          for (int a = 0; a < 3; ++a) {
            double grad = 0.0;
            if (n[a] > 1) {
              const bool lo = idx[a] > 0, hi = idx[a] < n[a] - 1;
              const std::size_t vm = lo ? v - step[a] : v;
              const std::size_t vp = hi ? v + step[a] : v;
              const double span = (lo && hi ? 2.0 : 1.0) * g.spacing[a];
              grad = (static_cast<double>(d[vp]) - static_cast<double>(d[vm])) / span;
            }
            out[v * stride + offset + static_cast<std::size_t>(a)] = static_cast<float>(grad);
          }
        }
  });
}

// Largest |value|; InputError on a non-finite value.
double max_abs_finite(const std::vector<float>& d, const char* what) {
  double m = 0.0;
  for (float x : d) {
    if (!std::isfinite(x))
      throw InputError(std::string(what) + ": distance map holds a non-finite value");
    m = std::max(m, static_cast<double>(std::fabs(x)));
  }
  return m;
}

void quantise(const std::vector<float>& d, double scale, std::vector<std::int16_t>& out) {
  out.resize(d.size());
  const double inv = 1.0 / scale;
  for (std::size_t v = 0; v < d.size(); ++v) {
    const double q = std::nearbyint(static_cast<double>(d[v]) * inv);
    out[v] = static_cast<std::int16_t>(std::clamp(q, -32767.0, 32767.0));
  }
}

}  // namespace

GradientScheme parse_gradient_scheme(std::string_view name) {
  if (name == "analytic") return GradientScheme::AnalyticTrilinear;
  if (name == "central") return GradientScheme::CentralDifference;
  if (name == "precomputed") return GradientScheme::PrecomputedField;
  throw UsageError("gradient scheme '" + std::string(name) +
                   "' is not one of analytic, central, precomputed");
}

Storage parse_storage(std::string_view name) {
  if (name == "float32") return Storage::Float32;
  if (name == "int16") return Storage::Int16;
  if (name == "interleaved") return Storage::Interleaved;
  throw UsageError("storage '" + std::string(name) + "' is not one of float32, int16, interleaved");
}

const char* to_string(GradientScheme scheme) {
  switch (scheme) {
    case GradientScheme::AnalyticTrilinear:
      return "analytic";
    case GradientScheme::CentralDifference:
      return "central";
    case GradientScheme::PrecomputedField:
      return "precomputed";
  }
  return "?";
}

const char* to_string(Storage storage) {
  switch (storage) {
    case Storage::Float32:
      return "float32";
    case Storage::Int16:
      return "int16";
    case Storage::Interleaved:
      return "interleaved";
  }
  return "?";
}

FieldSampler::FieldSampler(DistanceMap surf, DistanceMap bone, SamplerConfig config)
    : config_(config) {
  build(surf, &bone);
}

FieldSampler::FieldSampler(DistanceMap surf, DistanceMap bone, SamplerConfig config,
                           const Vec3d& origin)
    : config_(config) {
  build(surf, &bone);
  geometry_.origin[0] = origin.x;
  geometry_.origin[1] = origin.y;
  geometry_.origin[2] = origin.z;
}

FieldSampler::FieldSampler(DistanceMap surf, SamplerConfig config) : config_(config) {
  build(surf, nullptr);
}

void FieldSampler::build(DistanceMap& surf, DistanceMap* bone) {
  validate_grid(surf.grid, "skin distance map");
  if (surf.data.size() != surf.grid.voxel_count())
    throw UsageError("skin distance map: data size does not match its grid");
  if (bone) {
    if (bone->grid.dims != surf.grid.dims || bone->grid.spacing != surf.grid.spacing) {
      std::ostringstream msg;
      msg << "bone distance map grid " << bone->grid.dims[0] << "x" << bone->grid.dims[1] << "x"
          << bone->grid.dims[2] << " does not match the skin distance map grid "
          << surf.grid.dims[0] << "x" << surf.grid.dims[1] << "x" << surf.grid.dims[2]
          << " (dimensions and spacing must agree)";
      throw UsageError(msg.str());
    }
    if (bone->data.size() != bone->grid.voxel_count())
      throw UsageError("bone distance map: data size does not match its grid");
  }
  grid_ = surf.grid;
  has_bone_ = bone != nullptr;

  sampling::set_grid(geometry_, grid_);

  const double surf_max = max_abs_finite(surf.data, "skin");
  const double bone_max = bone ? max_abs_finite(bone->data, "bone") : 0.0;
  const bool precomputed = config_.gradient == GradientScheme::PrecomputedField;
  const std::size_t maps = has_bone_ ? 2 : 1;

  switch (config_.storage) {
    case Storage::Float32:
      surf_f32_ = std::move(surf.data);
      if (bone) bone_f32_ = std::move(bone->data);
      if (precomputed) {
        check_allocation(grid_, 12 * maps, "gradient field");
        surf_grad_.resize(3 * grid_.voxel_count());
        gradient_field(grid_, surf_f32_, surf_grad_.data(), 3, 0);
        if (bone) {
          bone_grad_.resize(3 * grid_.voxel_count());
          gradient_field(grid_, bone_f32_, bone_grad_.data(), 3, 0);
        }
      }
      break;
    case Storage::Int16:
      check_allocation(grid_, 2 * maps + (precomputed ? 12 * maps : 0), "int16 distance maps");
      surf_scale_ = surf_max > 0.0 ? surf_max / 32767.0 : 1.0;
      quantise(surf.data, surf_scale_, surf_i16_);
      if (bone) {
        bone_scale_ = bone_max > 0.0 ? bone_max / 32767.0 : 1.0;
        quantise(bone->data, bone_scale_, bone_i16_);
      }
      if (precomputed) {
        surf_grad_.resize(3 * grid_.voxel_count());
        gradient_field(grid_, surf.data, surf_grad_.data(), 3, 0);
        if (bone) {
          bone_grad_.resize(3 * grid_.voxel_count());
          gradient_field(grid_, bone->data, bone_grad_.data(), 3, 0);
        }
      }
      break;
    case Storage::Interleaved: {
      record_ = precomputed ? 8 : 2;
      check_allocation(grid_, 4 * record_, "interleaved distance maps");
      interleaved_.assign(record_ * grid_.voxel_count(), 0.0f);
      for (std::size_t v = 0; v < grid_.voxel_count(); ++v) {
        interleaved_[v * record_] = surf.data[v];
        interleaved_[v * record_ + 1] = bone ? bone->data[v] : 0.0f;
      }
      if (precomputed) {
        gradient_field(grid_, surf.data, interleaved_.data(), record_, 2);
        if (bone) gradient_field(grid_, bone->data, interleaved_.data(), record_, 5);
      }
      break;
    }
  }
  // The caller's maps (moved in by value) are released when the constructor returns.
}

std::size_t FieldSampler::bytes_per_voxel() const {
  const std::size_t maps = has_bone_ ? 2 : 1;
  const bool precomputed = config_.gradient == GradientScheme::PrecomputedField;
  switch (config_.storage) {
    case Storage::Float32:
      return maps * (4 + (precomputed ? 12 : 0));
    case Storage::Int16:
      return maps * (2 + (precomputed ? 12 : 0));
    case Storage::Interleaved:
      return 4 * record_;
  }
  return 0;
}

FieldSample FieldSampler::sample_surf(const Vec3d& x) const {
  return dispatch([&](const auto& access) { return access.surf_at(x); });
}

FieldSample FieldSampler::sample_bone(const Vec3d& x) const {
  if (!has_bone_) return FieldSample{};
  return dispatch([&](const auto& access) { return access.bone_at(x); });
}

double FieldSampler::bone_value(const Vec3d& x) const {
  if (!has_bone_) return kOutsideValue;
  return dispatch([&](const auto& access) { return access.bone_value_at(x); });
}

void FieldSampler::prepare_bone_beneath() const {
  if (!has_bone_) return;
  std::call_once(beneath_->once, [this] {
    beneath_->map = bone_beneath_map(*this);
    beneath_->ready.store(beneath_->map.data(), std::memory_order_release);
  });
}

void FieldSampler::adopt_bone_beneath(std::vector<float> map) const {
  if (map.size() != grid_.voxel_count())
    throw UsageError("bone-beneath map: its size does not match the maps");
  bool adopted = false;
  std::call_once(beneath_->once, [&] {
    beneath_->map = std::move(map);
    beneath_->ready.store(beneath_->map.data(), std::memory_order_release);
    adopted = true;
  });
  if (!adopted) throw UsageError("bone-beneath map: already prepared");
}

bool FieldSampler::has_bone_beneath() const {
  return bone_beneath_data() != nullptr;
}

const float* FieldSampler::bone_beneath_data() const {
  return beneath_ ? beneath_->ready.load(std::memory_order_acquire) : nullptr;
}

}  // namespace palp
