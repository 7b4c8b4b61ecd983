// Notches of a mask: voxels outside it with the mask on at least `faces` (4 or more) of their
// six faces, filled until none is left (the least such closure, the same in any order). Only
// voxels `room` holds are filled. The bone's partial volume in a pit or gap narrower than a voxel
// (segment_bone, room = the body) and a lumen's sliver or edge corner read as cortex
// (prep/vessel, room = the body below dense cortex). 0 faces: nothing.
#pragma once

#include "base/volume.hpp"

namespace palp::segmentation {

void fill_notches(const Mask& room, int faces, Mask& mask);

}  // namespace palp::segmentation
