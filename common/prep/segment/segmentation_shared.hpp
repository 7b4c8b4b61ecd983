// Internal helpers that body and bone segmentation share: parameter checks, integer HU limits.
#pragma once

#include "prep/segment/segmentation.hpp"

namespace palp::segmentation {

// Throws UsageError for unusable parameters: not finite, negative sizes, or bone_grow_hu above
// bone_seed_hu.
void check_params(const SegmentationParams& p);

// HU stored as integers: hu > threshold exactly when hu > floor(threshold).
int integer_floor(double hu);

}  // namespace palp::segmentation
