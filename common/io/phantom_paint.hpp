// Internal to the torso's and the trunk's sources: the row painter both draw with. A row of
// voxels (fixed j, k) is painted layer after layer, each shape blending its HU in by its
// partial-volume coverage and claiming the voxels whose centres it covers (coverage >= 1/2) for
// its tissue (and, for the trunk's bones, its label). Not part of palp::io's interface.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "io/phantom_shapes.hpp"

namespace palp::phantom_detail {

// Maps voxel indices to the anatomy frame: anatomy = (scene - centre) / scale.
struct AnatomyFrame {
  Vec3 centre;
  double scale;
  Vec3 spacing;
  double coord(int axis, std::int64_t index) const {
    return (static_cast<double>(index) * spacing[axis] - centre[axis]) / scale;
  }
  Vec3 voxel_size() const { return {spacing[0] / scale, spacing[1] / scale, spacing[2] / scale}; }
};

struct RowBuffers {
  std::vector<double> hu;
  std::vector<Tissue> tissue;
  std::vector<std::uint8_t> label;  // empty: no labels drawn
};

template <class S>
void paint_shape_row(const S& shape, double hu, Tissue tissue, std::uint8_t label,
                     const RowContext& row, const AnatomyFrame& frame, RowBuffers& buf) {
  const RowSpans spans = shape.spans(row);
  const std::int64_t nx = static_cast<std::int64_t>(buf.hu.size());
  const double sx = frame.spacing[0] / frame.scale;
  const double x0 = frame.coord(0, 0);
  const bool labels = !buf.label.empty();
  for (int s = 0; s < spans.count; ++s) {
    const double last = static_cast<double>(nx - 1);
    const auto lo = static_cast<std::int64_t>(
        std::clamp(std::ceil((spans.spans[s][0] - x0) / sx), 0.0, last + 1.0));
    const auto hi = static_cast<std::int64_t>(
        std::clamp(std::floor((spans.spans[s][1] - x0) / sx), -1.0, last));
    for (std::int64_t i = lo; i <= hi; ++i) {
      const double x = x0 + static_cast<double>(i) * sx;
      const double a = (x >= spans.full_lo && x <= spans.full_hi)
                           ? spans.row_factor
                           : shape.coverage(x, row, spans.row_factor);
      if (a <= 0.0) continue;
      buf.hu[i] += (hu - buf.hu[i]) * a;
      if (a >= 0.5) {
        buf.tissue[i] = tissue;
        if (labels) buf.label[i] = label;
      }
    }
  }
}

inline void write_truth(const RowBuffers& buf, std::size_t base, PhantomTruth& truth) {
  for (std::size_t i = 0; i < buf.tissue.size(); ++i) {
    const Tissue t = buf.tissue[i];
    const bool artery = t == Tissue::kArteryContrast || t == Tissue::kArteryPlain;
    truth.body.data[base + i] = t != Tissue::kOutside && t != Tissue::kEquipment;
    truth.bone.data[base + i] = t == Tissue::kBone || t == Tissue::kMetal;
    truth.equipment.data[base + i] = t == Tissue::kEquipment;
    truth.vessel.data[base + i] = t == Tissue::kArteryContrast || t == Tissue::kVeinContrast;
    truth.artery.data[base + i] = artery;
    truth.metal.data[base + i] = t == Tissue::kMetal;
    truth.liver.data[base + i] = t == Tissue::kLiver;
  }
}

}  // namespace palp::phantom_detail
