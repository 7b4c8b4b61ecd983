// Keeping only what a device can reach: a window of a scene's distance maps (issue "model no
// more than a scene needs"). A device reaches a box of the scene (its workspace placed on the
// patient) and the tool's points lie at most its reach from the device point; the force model
// never reads a map outside that box, so a sampler built on the window (FieldSampler with an
// origin) answers every tick exactly as the whole-volume one does, from a fraction of the memory.
// Points outside the window sample as outside the grid: no contact, no force.
#pragma once

#include <memory>

#include "base/vec.hpp"
#include "base/volume.hpp"
#include "model/field_sampler.hpp"

namespace palp {

struct MapWindow {
  Index3 lo{0, 0, 0};  // first voxel (inclusive)
  Index3 dims{0, 0, 0};
  Vec3d origin{};  // scene position of voxel lo
};

// The voxels any sample at a point of the scene box [box_lo, box_hi] (mm) reads, with every
// gradient scheme: the box's cells, their corners and one voxel more on each side (central
// differences and the precomputed field reach a neighbour further), clamped to the grid. UsageError
// for a box that misses the grid or is not a box (lo > hi, non-finite).
MapWindow window_for_box(const Grid& grid, const Vec3d& box_lo, const Vec3d& box_hi);

// The window's voxels of `map`, on a grid of the window's dims whose world placement is moved
// to the window's first voxel (so the cropped file would still land on the patient).
DistanceMap crop(const DistanceMap& map, const MapWindow& window);

// A sampler on `window` of the scene maps `surf` and `bone` that answers every sample inside the
// window's box exactly as `whole` (a sampler on the same maps, any config) does: the maps are
// cropped, and palp's bone-beneath map, whose rays run far beyond any box, is traced on `whole`
// and cropped too. `config` is the window sampler's scheme and storage.
std::shared_ptr<const FieldSampler> window_sampler(const DistanceMap& surf, const DistanceMap& bone,
                                                   const FieldSampler& whole,
                                                   const MapWindow& window, SamplerConfig config);

}  // namespace palp
