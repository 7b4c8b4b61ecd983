#include "model/bone_beneath.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "model/field_sampler.hpp"

namespace palp {

namespace {

// The centre of voxel (i, j, k) in the scene frame.
Vec3d voxel_centre(const Grid& g, const Vec3d& origin, std::int64_t i, std::int64_t j,
                   std::int64_t k) {
  return origin + Vec3d{static_cast<double>(i) * g.spacing[0],
                        static_cast<double>(j) * g.spacing[1],
                        static_cast<double>(k) * g.spacing[2]};
}

// Each voxel's bone beneath: the nearest bone, or within the skin's band the length of the ray
// along the inward normal to the bone (those voxels marked in `traced` when it is not empty).
std::vector<float> trace_bone_beneath(const FieldSampler& fields, const BoneBeneathOptions& opt,
                                      std::vector<std::uint8_t>& traced) {
  const Grid& g = fields.grid();
  std::vector<float> out(g.voxel_count(), 0.0f);
  const double outside_margin = 2.0 * std::max({g.spacing[0], g.spacing[1], g.spacing[2]});
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const Vec3d origin = fields.origin();
  parallel_for_chunks(nz, 1, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t k = k0; k < k1; ++k)
      for (std::int64_t j = 0; j < ny; ++j)
        for (std::int64_t i = 0; i < nx; ++i) {
          const Vec3d c = voxel_centre(g, origin, i, j, k);
          const double near = -fields.bone_value(c);  // distance to the nearest bone
          double beneath = std::max(0.0, near);
          const FieldSample skin = fields.sample_surf(c);
          const double gn = norm(skin.grad);
          if (near > 0.0 && skin.value >= -outside_margin && skin.value <= opt.band_mm &&
              gn > 1e-9) {
            // Sphere tracing along the inward normal: steps of D_bone never pass bone, so the
            // length is a lower bound, short by at most hit_mm / cos(ray, bone normal).
            const Vec3d dir = skin.grad * (1.0 / gn);
            double t = near;
            for (int s = 0; s < opt.max_steps && t < opt.cap_mm; ++s) {
              const double d = -fields.bone_value(c + t * dir);  // 1e9 beyond the grid
              if (d <= opt.hit_mm) break;
              t += d;
            }
            beneath = std::min(t, opt.cap_mm);
            if (opt.pad_widen) traced[g.linear(i, j, k)] = 1;
          }
          out[g.linear(i, j, k)] = static_cast<float>(beneath);
        }
  });
  return out;
}

// The pad's reach: each traced voxel also takes its neighbours' rays, moved to it along its
// normal (t_n + (n - c) . dir: the same value where the bone beneath is flat), and keeps the
// nearest. The tick interpolates the map trilinearly, and between a ray that hits a rib and
// one that misses it (80 mm) the average reads as no rib at all; a finger's pad, 15 mm across,
// feels a rib anywhere under it. So a rib's edge moves out by one voxel at most.
std::vector<float> widen_under_pad(const FieldSampler& fields, const BoneBeneathOptions& opt,
                                   const std::vector<float>& out,
                                   const std::vector<std::uint8_t>& traced) {
  const Grid& g = fields.grid();
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const Vec3d origin = fields.origin();
  std::vector<float> widened = out;
  parallel_for_chunks(nz, 1, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t k = k0; k < k1; ++k)
      for (std::int64_t j = 0; j < ny; ++j)
        for (std::int64_t i = 0; i < nx; ++i) {
          const std::size_t at = g.linear(i, j, k);
          if (!traced[at]) continue;
          const Vec3d c = voxel_centre(g, origin, i, j, k);
          const FieldSample skin = fields.sample_surf(c);
          const double gn = norm(skin.grad);
          if (!(gn > 1e-9) || skin.value > opt.band_mm) continue;
          const Vec3d dir = skin.grad * (1.0 / gn);
          double best = out[at];
          for (int dk = -1; dk <= 1; ++dk)
            for (int dj = -1; dj <= 1; ++dj)
              for (int di = -1; di <= 1; ++di) {
                const std::int64_t a = i + di, b = j + dj, e = k + dk;
                if (a < 0 || b < 0 || e < 0 || a >= nx || b >= ny || e >= nz) continue;
                const std::size_t nb = g.linear(a, b, e);
                const float tn = out[nb];
                if (!traced[nb] || !(tn < opt.cap_mm)) continue;
                // The bone plane the neighbour's ray met (normal m at its hit point), reached
                // from c along dir: t_n + ((n - c) . m) / (dir . m).
                const Vec3d off{di * g.spacing[0], dj * g.spacing[1], dk * g.spacing[2]};
                const Vec3d hit = c + off + static_cast<double>(tn) * dir;
                const Vec3d m = fields.sample_bone(hit).grad;
                const double dm = dot(dir, m);
                if (!(dm > 0.5 * norm(m))) continue;  // a grazing plane: no estimate
                best = std::min(best, std::max(0.0, tn + dot(off, m) / dm));
              }
          widened[at] = static_cast<float>(std::max(best, std::max(0.0, -fields.bone_value(c))));
        }
  });
  return widened;
}

}  // namespace

std::vector<float> bone_beneath_map(const FieldSampler& fields, const BoneBeneathOptions& opt) {
  if (!fields.has_bone()) throw UsageError("bone beneath the skin: the scene has no bone map");
  const Grid& g = fields.grid();
  check_allocation(g, sizeof(float), "bone-beneath map");
  std::vector<std::uint8_t> traced(opt.pad_widen ? g.voxel_count() : 0, 0);
  std::vector<float> out = trace_bone_beneath(fields, opt, traced);
  if (!opt.pad_widen) return out;
  return widen_under_pad(fields, opt, out, traced);
}

}  // namespace palp
