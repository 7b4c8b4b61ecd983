// Removal of the table, pad, mattress and cables below the patient, slice by slice.
#pragma once

#include <cstdint>

#include "base/volume.hpp"
#include "prep/segment/segmentation.hpp"

namespace palp::segmentation {

// Clears the table bands of every axial slice of `mask` (see table_removal.cpp); returns how many
// voxels were cleared.
std::uint64_t remove_table(const PatientAxes& axes, const SegmentationParams& params, Mask& mask);

}  // namespace palp::segmentation
