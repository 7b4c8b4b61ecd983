#include "model/bone_beneath.hpp"

#include <algorithm>
#include <cmath>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "model/field_sampler.hpp"

namespace palp {

std::vector<float> bone_beneath_map(const FieldSampler& fields, const BoneBeneathOptions& opt) {
  if (!fields.has_bone()) throw UsageError("bone beneath the skin: the scene has no bone map");
  const Grid& g = fields.grid();
  check_allocation(g, sizeof(float), "bone-beneath map");
  std::vector<float> out(g.voxel_count(), 0.0f);
  const double outside_margin = 2.0 * std::max({g.spacing[0], g.spacing[1], g.spacing[2]});
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const Vec3d origin = fields.origin();

  parallel_for_chunks(nz, 1, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t k = k0; k < k1; ++k)
      for (std::int64_t j = 0; j < ny; ++j)
        for (std::int64_t i = 0; i < nx; ++i) {
          const Vec3d c = origin + Vec3d{static_cast<double>(i) * g.spacing[0],
                                         static_cast<double>(j) * g.spacing[1],
                                         static_cast<double>(k) * g.spacing[2]};
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
          }
          out[g.linear(i, j, k)] = static_cast<float>(beneath);
        }
  });
  return out;
}

}  // namespace palp
