// The reading every label format shares: a label file's voxels, read slab by slab, checked (whole
// numbers 0..65535), counted per class, and put on the CT's grid nearest-neighbour through both
// grids' world placements.
//
// Memory: the label file is never held whole. The reader keeps one slab of label slices, at most
// kSlabValues values (64 MiB as uint16) or one slice if a slice is larger (a slice is at most
// kSlabValues values: larger ones are refused), and a 1 MiB buffer of stored bytes; what it writes
// goes into volumes on the CT's grid the caller gives (palp: one byte per CT voxel and layer, a
// structure's id in each; the masks are cut from them afterwards). Nothing is read
// before the header has been checked against the file's size (raw voxels must all be in the
// file, compressed ones within deflate's 1032:1 of it).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "base/volume.hpp"
#include "io/stored_image.hpp"

namespace palp::labels {

// One label file as its header describes it.
struct LabelVolume {
  StoredImage image;            // the grid (LPS) and where the voxels are
  std::int64_t components = 1;  // values per voxel (3D Slicer's layers), next to each other
  std::string name;             // the file, as messages name it
};

inline constexpr std::uint32_t kMaxLabelValue = 65535;
inline constexpr std::size_t kSlabValues = std::size_t{32} << 20;

// What the stored values mean: table[component][value] is a class index, kBackground, or (also
// for values past the table's end) kUndefined.
struct LabelLookup {
  static constexpr std::int32_t kBackground = -1;
  static constexpr std::int32_t kUndefined = -2;
  std::vector<std::vector<std::int32_t>> table;

  std::int32_t at(std::size_t component, std::uint32_t value) const {
    const auto& values = table[component];
    return value < values.size() ? values[value] : kUndefined;
  }
};

struct LabelCounts {
  std::vector<std::uint64_t> in_file;  // per class: values of the class in the file
  std::vector<std::uint64_t> on_ct;    // per class: CT voxels the class was written to
  std::uint64_t labelled_in_file = 0;  // file voxels with any value other than 0
  std::uint64_t ct_covered = 0;        // CT voxels whose nearest label voxel is in the file
  std::uint32_t max_value = 0;         // the largest value in the file
  // The first undefined value met (component, value) and how many values were undefined.
  std::uint64_t undefined = 0;
  std::int64_t undefined_component = 0;
  std::uint32_t undefined_value = 0;
  // CT voxels a class was written to that already held another value (another structure's id):
  // how many, and the first one (its linear index, the value there, the class written).
  std::uint64_t overlaps = 0;
  std::size_t overlap_at = 0;
  std::uint8_t overlap_previous = 0;
  std::int32_t overlap_class = 0;
  bool resampled = false;  // the file's voxels are not the CT's (nor a box of them)
};

// Where class `cls` is written: a volume on the CT's grid (allocated by the caller at first use)
// and the value written there.
struct ClassTarget {
  Mask* volume = nullptr;
  std::uint8_t value = 1;
};
using TargetOfClass = std::function<ClassTarget(std::int32_t cls)>;

// Reads `volume`, counts every value, and writes, for each CT voxel, the targets of the classes
// its nearest label voxel holds (a voxel that held another value is counted as an overlap).
// InputError for a lying header, a truncated file, a value that is not a whole number 0..65535, a
// slice larger than `slab_values` values, and a file that does not overlap the CT. Undefined values
// are only counted: the caller names them. (`slab_values` is kSlabValues; tests pass less to cross
// slabs on small files.)
LabelCounts read_labels(const LabelVolume& volume, const Grid& ct, const LabelLookup& lookup,
                        std::size_t classes, const TargetOfClass& target_of,
                        std::size_t slab_values = kSlabValues);

// True when the two grids have the same dims and place their voxels at the same points (within
// 1e-5 of a voxel per axis and 1e-3 voxel in origin).
bool same_grid(const Grid& a, const Grid& b);

// "1.5 x 1.5 x 1.5 mm (300 x 300 x 200 voxels)", for notes.
std::string describe_grid(const Grid& grid);

}  // namespace palp::labels
