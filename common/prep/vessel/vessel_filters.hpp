// The vessel search's filters over the CT (vessel_filters.cpp): the smoothed HU its levels are
// read from, and cortex as a bright ridge.
#pragma once

#include <cstdint>
#include <vector>

#include "base/volume.hpp"

namespace palp {

// The 3x3x3 mean of `ct` (a voxel's own 27, the scan's border voxels repeated beyond it), as
// three means of three along i, j and k, each rounded half away from zero.
std::vector<std::int16_t> smoothed_hu(const CtVolume& ct);

// Cortex: a bright ridge. A voxel at or above `level_hu` whose neighbours one and two voxels
// away, averaged, lie below it by `drop` of its height above the soft tissue (`soft_hu`) on BOTH
// sides along one of the 13 directions through it: a shell up to three voxels thick with
// something darker on either side (marrow inside, soft tissue outside), or a trabecula. A
// lumen's edge is a step, not a ridge: bright on the inside, dark only outside; a pool of
// contrast, however bright, is flat; inside a thick bright body (bright two voxels deep along
// half the 26 rays or more) no voxel is one. The mask holds, for each ridge voxel, along how
// many of the 13 directions it is one (1-13).
Mask ridge_cortex(const CtVolume& ct, double level_hu, double soft_hu, double drop);

}  // namespace palp
