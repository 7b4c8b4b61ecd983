// Volumes on a regular grid: the CT in HU, masks, and distance maps.
//
// Scene frame (spec "Frames and units"): the grid's index axes scaled by spacing, voxel (0,0,0)
// at the origin, so voxel (i,j,k) sits at (i*sx, j*sy, k*sz) mm. Storage order: i fastest.
// The file's own world placement (origin, direction) is kept as metadata in LPS (the DICOM /
// ITK convention) and written back on export; it never changes scene coordinates.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace palp {

using Index3 = std::array<std::int64_t, 3>;
using Vec3 = std::array<double, 3>;

// Where the grid sits in the scanner's world (LPS, mm): world = origin + direction * (spacing .*
// ijk). direction is row-major 3x3 whose columns are the i, j, k axis directions.
struct WorldPlacement {
  Vec3 origin{0.0, 0.0, 0.0};
  std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};
  bool operator==(const WorldPlacement&) const = default;
};

struct Grid {
  Index3 dims{0, 0, 0};
  Vec3 spacing{1.0, 1.0, 1.0};  // mm
  WorldPlacement world;

  std::size_t voxel_count() const {
    return static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1]) *
           static_cast<std::size_t>(dims[2]);
  }
  std::size_t linear(std::int64_t i, std::int64_t j, std::int64_t k) const {
    return static_cast<std::size_t>(i + dims[0] * (j + dims[1] * k));
  }
  bool contains(std::int64_t i, std::int64_t j, std::int64_t k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < dims[0] && j < dims[1] && k < dims[2];
  }
  double min_spacing() const;
  double max_spacing() const;
  // Extent of the grid in the scene frame (centre of first to centre of last voxel), mm.
  Vec3 extent_mm() const;
  bool operator==(const Grid&) const = default;
};

// Throws UsageError / InputError when dims or spacing are not a usable grid (zero, negative,
// non-finite, more than kMaxVoxelsPerAxis along an axis).
void validate_grid(const Grid& grid, const std::string& what);

// Refuses, before allocating, a volume of `bytes_per_voxel` that would not fit in memory:
// throws ResourceError naming `what`, the size asked for and the memory available.
void check_allocation(const Grid& grid, std::size_t bytes_per_voxel, const std::string& what);

// Physical memory the kernel reports as available to new allocations (bytes), 0 if unknown.
std::size_t available_memory_bytes();
// Peak resident set size of this process so far (bytes), 0 if unknown.
std::size_t peak_rss_bytes();

inline constexpr std::int64_t kMaxVoxelsPerAxis = 16384;
// Voxel spacing palp accepts (mm): from micro-CT (1 µm) to a coarse planning scan's slices;
// outside it a header lies or a unit is wrong, and distance transforms and ray marches would spin.
inline constexpr double kMinSpacingMm = 0.001;
inline constexpr double kMaxSpacingMm = 100.0;

template <class T>
struct Volume {
  Grid grid;
  std::vector<T> data;

  Volume() = default;
  // Allocates a zero-filled volume after check_allocation.
  explicit Volume(const Grid& g, T fill = T{}, const std::string& what = "volume");

  T& at(std::int64_t i, std::int64_t j, std::int64_t k) { return data[grid.linear(i, j, k)]; }
  const T& at(std::int64_t i, std::int64_t j, std::int64_t k) const {
    return data[grid.linear(i, j, k)];
  }
  std::size_t size() const { return data.size(); }
};

using CtVolume = Volume<std::int16_t>;  // Hounsfield units
using Mask = Volume<std::uint8_t>;      // 0 / 1
using DistanceMap = Volume<float>;      // signed distance, mm, positive inside

template <class T>
Volume<T>::Volume(const Grid& g, T fill, const std::string& what) : grid(g) {
  validate_grid(g, what);
  check_allocation(g, sizeof(T), what);
  data.assign(g.voxel_count(), fill);
}

}  // namespace palp
