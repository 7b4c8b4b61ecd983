// The same voxels stored in another axis order (an orientation code such as "RAS", "LPS", "PIL"):
// each new index axis grows toward the patient direction its letter names ("towards" convention,
// base/patient_frame.hpp), and the world placement follows, so every voxel keeps its patient (LPS
// world) position and only the voxel order, the direction matrix and the origin change. prep's
// reorder_axes (`palp phantom --orientation`) and the phantoms' `orient` option both use it.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

#include "base/volume.hpp"

namespace palp {

struct AxisReorder {
  Grid grid;                       // the reordered grid (dims, spacing, direction, origin)
  std::array<int, 3> source{};     // the source index axis each new axis reads
  std::array<bool, 3> reversed{};  // whether it reads that axis backwards
};

// UsageError for a code that is not three letters, one from each of L/R, P/A, S/I; InputError for
// an oblique grid (no patient axis per index axis).
AxisReorder axis_reorder(const Grid& grid, std::string_view code);

// `volume` stored as `reorder` says (reorder computed from volume.grid).
template <class T>
Volume<T> reorder_volume(const Volume<T>& volume, const AxisReorder& reorder,
                         const char* what = "reordered volume") {
  const Grid& g = volume.grid;
  Volume<T> out(reorder.grid, T{}, what);
  std::int64_t src[3];
  for (std::int64_t k = 0; k < out.grid.dims[2]; ++k)
    for (std::int64_t j = 0; j < out.grid.dims[1]; ++j)
      for (std::int64_t i = 0; i < out.grid.dims[0]; ++i) {
        const std::int64_t idx[3] = {i, j, k};
        for (std::size_t a = 0; a < 3; ++a) {
          const auto b = static_cast<std::size_t>(reorder.source[a]);
          src[b] = reorder.reversed[a] ? g.dims[b] - 1 - idx[a] : idx[a];
        }
        out.at(i, j, k) = volume.at(src[0], src[1], src[2]);
      }
  return out;
}

}  // namespace palp
