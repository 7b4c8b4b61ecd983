// palp's "bone beneath the skin": for each voxel centre c near the skin, the distance from c
// along the skin's inward normal (grad D_surf / |grad D_surf|) to the bone surface, so the tick
// reads the distance along the normal with one trilinear sample instead of tracing a ray.
//
// Why a map: the distance field D_bone gives the distance to the NEAREST bone, in any direction.
// Over an intercostal space the nearest bone is the rib beside the finger, not anything beneath
// it, so a bound built from a few sphere-tracing steps of D_bone (what the tick did before) stays
// far below the true distance along the normal and the space felt almost like a rib (real CT,
// finger:1 at 6 mm: a space 41 mm above bone got 5.6 N of bone force). Tracing to convergence in
// the tick would cost up to tens of samples per point; traced once here, it costs one.
#pragma once

#include <vector>

namespace palp {

class FieldSampler;

struct BoneBeneathOptions {
  double band_mm = 40.0;  // traced for voxels at skin depth <= band_mm (and just outside)
  double cap_mm = 80.0;   // farther bone (or none) reads cap_mm: f_b(80 mm) is ~0.02 N
  double hit_mm = 0.05;   // a ray this close to bone has reached it
  int max_steps = 96;     // bound per voxel (a grazing ray); the sum so far is a lower bound
  bool pad_widen = true;  // each voxel keeps the nearest of its neighbours' rays (see the .cpp)
};

// The map on the sampler's grid (one float per voxel, mm): traced where the skin has a
// direction within the band (with pad_widen, each traced voxel then keeps the nearest of its own
// and its neighbours' traced rays, moved to it along the bone plane each met); elsewhere max(0,
// -D_bone(c)), the nearest bone, a lower bound of the distance along any direction. Zero inside
// bone. Needs a bone map (UsageError otherwise).
std::vector<float> bone_beneath_map(const FieldSampler& fields, const BoneBeneathOptions& opt = {});

}  // namespace palp
