// Marrow between cortices: voxels that bone brackets along most directions (bone_enclosure.cpp).
#pragma once

#include "prep/segment/segmentation.hpp"

namespace palp::segmentation {

// Adds to `bone` (0/1) every body voxel outside it that has bone on both sides, each within
// params.bone_enclosure_radius_mm, along at least params.bone_enclosure_directions of the 13 lines
// through it (the 3x3x3 neighbourhood's axes, face and edge diagonals and body diagonals). Leaving
// the scan through its first or last slice counts as bone (the scan cuts a bone there). Nothing
// with bone_enclosure_directions 0. Also, when params.bone_plate_radius_mm exceeds the radius, a
// voxel that bone brackets within the plate radius along as many lines, the line across the
// slices (the body axis) among them: the marrow of a plate whose cortices lie farther apart (the
// sacrum), while the spinal canal, a tube open along the axis, is not bracketed along it however
// near its arches come along the tilted lines.
//
// The slice-plane votes (bone_marrow.hpp) need a hole closed in a plane; the sacrum, the pelvis
// between its two cortices and a femoral head are open through foramina, a thin or missing cortex
// or a joint in every plane, yet bone brackets most of their marrow along most lines. The spinal
// canal stays open: along the spine (the axis and the lines tilted from it) a canal voxel meets
// no bone within the radius, so it lacks the directions.
void fill_between_cortices(const PatientAxes& axes, const SegmentationParams& params,
                           const Mask& body, Mask& bone);

}  // namespace palp::segmentation
