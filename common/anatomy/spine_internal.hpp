// The steps of find_spine (spine_levels.hpp), each in its own file.
#pragma once

#include <vector>

#include "anatomy/spine_levels.hpp"

namespace palp::anatomy {

// spine_column.cpp: the body block per slice and the smoothed centre line.
std::vector<ColumnSlice> find_column(const PatientMask& bone, const std::vector<SliceBody>& bodies);

// One sample of the anterior column's profile: a cross-section perpendicular to the centre
// line, every kProfileStepMm of its length.
struct ProfileSample {
  double z = 0.0;         // index z of the section's centre
  double fraction = 0.0;  // of the section's points in bone
  Vec3d bone_sum{};       // sum of the bone points (index units), for centroids
  double bone_points = 0.0;
};
inline constexpr double kProfileStepMm = 1.0;

// spine_levels.cpp
std::vector<ProfileSample> column_profile(const PatientMask& bone,
                                          const std::vector<ColumnSlice>& column);
std::vector<VertebraSegment> split_at_discs(const PatientMask& bone,
                                            const std::vector<ColumnSlice>& column,
                                            const std::vector<ProfileSample>& profile);

// spine_tips.cpp: each segment's spinous-process tip (not the sacrum's).
void find_spinous_tips(const PatientMask& bone, const std::vector<ColumnSlice>& column,
                       std::vector<VertebraSegment>& segments);

// spine_names.cpp: the lateral extent through each body, and the sacrum among the lowest.
void measure_widths(const PatientMask& bone, const std::vector<ColumnSlice>& column,
                    std::vector<VertebraSegment>& segments);
void find_sacrum(Spine& spine);

}  // namespace palp::anatomy
