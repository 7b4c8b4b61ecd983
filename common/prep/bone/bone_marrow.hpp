// Marrow and the bone's partial-volume rim, by enclosure in orthogonal slices (bone_marrow.cpp).
#pragma once

#include "prep/segment/segmentation.hpp"

namespace palp::segmentation {

// Adds to `bone` (0/1) the voxels that at least params.bone_marrow_votes of the three orthogonal
// slice planes through them (axial, coronal, sagittal) call enclosed: a hole of at most
// params.bone_max_hole_mm2 in the plane's bone after a 3x3 closing, or a voxel the closing adds.
// In the coronal and sagittal planes the scan's first and last slices do not open a hole: the
// scan cuts bones there. Marrow is enclosed in all three planes; the spinal canal only axially.
void fill_marrow_by_votes(const PatientAxes& axes, const SegmentationParams& params, Mask& bone);

}  // namespace palp::segmentation
