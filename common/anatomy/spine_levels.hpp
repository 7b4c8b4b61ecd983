// The vertebral column of a scan: its anterior column (the vertebral bodies) followed from slice
// to slice near the posterior midline, split into vertebrae at the discs, the sacrum told by its
// width, the spinous processes' tips, and the names counted from the sacrum up (or from the
// lowest rib-bearing vertebra, T12, when there is no sacrum).
//
// Everything here is in patient index units (PatientMask: x left, y posterior, z superior).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "anatomy/patient_volume.hpp"
#include "base/vec.hpp"

namespace palp::anatomy {

// The anterior column in one axial slice: the block of rows whose bone run through the midline
// is at least a vertebral body wide (kMinBodyWidthMm), and the smoothed centre line through it.
struct ColumnSlice {
  bool found = false;       // a body block in this slice (before smoothing)
  bool on_column = false;   // within the column's superior-inferior range
  double x = 0.0, y = 0.0;  // the centre line (smoothed, interpolated over the discs)
  double depth = 0.0;       // the body's anterior-posterior depth (smoothed), index units of y
};

struct VertebraSegment {
  double z_lo = 0.0, z_hi = 0.0;  // bounding discs' mid-planes (or the column's ends), index z
  bool cut = false;               // touches the column's end at the scan's edge
  Vec3d centre{};                 // the body's centre (index units)
  double height_mm = 0.0;
  double width_mm = 0.0;     // the bone's lateral extent through the body (the sacrum's alae)
  double gap_clarity = 0.0;  // how empty its bounding discs are: 1 - bone fraction / body's
  std::optional<Vec3d> spinous_tip;  // index units
  bool sacrum = false;
  std::optional<std::string> name;
  double confidence = 0.0;
  std::string reason;
};

struct Spine {
  std::vector<ColumnSlice> column;        // per slice z
  std::vector<VertebraSegment> segments;  // inferior to superior
  int sacrum = -1;                        // index into segments, -1 when none was found
  std::string sacrum_reason;              // why there is none
  std::vector<std::string> notes;
};

// A vertebral body is at least this wide (mm): T1's is about 25 mm, the lumbar bodies 40-50 mm;
// a spinous process or a lamina's junction is narrower.
inline constexpr double kMinBodyWidthMm = 18.0;
// The sacrum with its alae, joined to the ilia at the sacroiliac joints, is at least this many
// times as wide as the lumbar bodies above it (100-130 mm against 40-55 mm).
inline constexpr double kSacrumWidthRatio = 1.6;
// A sacrum at least twice as tall as the median vertebra (S1-S5 fused, 90-110 mm along its
// curve) need only be this many times as wide.
inline constexpr double kFusedSacrumWidthRatio = 1.3;

// The column, its vertebrae and their spinous tips; no names yet.
Spine find_spine(const PatientMask& bone, const std::vector<SliceBody>& bodies);

// Names the segments: from the sacrum up (L5..L1, T12, ...), or, without a sacrum, from the
// vertebra `lowest_rib_vertebra` (index into segments) as T12. `lowest_rib_vertebra` also checks
// the count from the sacrum (T12 must bear the lowest rib). Sets confidences and reasons.
void name_vertebrae(Spine& spine, std::optional<int> lowest_rib_vertebra);

// The segment whose [z_lo, z_hi) holds index z, or -1.
int segment_at(const Spine& spine, double z);

}  // namespace palp::anatomy
