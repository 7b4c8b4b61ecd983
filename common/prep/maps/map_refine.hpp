// Distance maps on a grid finer than a coarse CT's (`palp prep --map-spacing MM`).
//
// On a CT whose coarsest spacing exceeds `map_spacing_mm`, prep writes both maps on the CT's grid
// refined by an integer factor k_a per axis, k_a = ceil(s_a / map_spacing_mm), with nodes aligned
// to the CT's: n'_a = (n_a - 1) k_a + 1, the same origin and direction, so a scene point
// (mm from voxel (0,0,0)'s centre) is the same point on both grids and the scene frame does not
// change. The coarse maps are upsampled trilinearly at the fine nodes, which reproduces their
// trilinear interpolant exactly (to float rounding of the nodes): a map the tick reads on the
// fine grid is the same function as on the coarse one. d_surf's nodes within the skin band are
// then projected onto the trilinear HU's iso-surface (iso_projection.hpp) on the fine grid, so
// only the skin near its surface gains accuracy. The refined grid is capped at
// kMaxRefinedVoxels (the factor of the coarsest axis is lowered first).
#pragma once

#include <array>
#include <cstdint>

#include "base/volume.hpp"

namespace palp {

using Refinement = std::array<int, 3>;  // k per axis, 1 = not refined

// The default of --map-spacing (mm): 0, the maps on the CT's own grid voxel for voxel, as the
// spec's prep outputs are. Refinement is asked for (docs/prep.md "Finer maps for coarse CTs": on
// the 3 mm CT, 2 mm takes the skin's 6 mm ripple 0.184 -> 0.145 N for 4.6x palpd's memory).
inline constexpr double kDefaultMapSpacingMm = 0.0;
// The spacing the docs' and tests' refined figures use: the 3 mm CT's maps at 1.5 mm; the torso
// phantom's 2 mm slices and the prep benchmarks' grids (<= 1.5 mm) stay as they are.
inline constexpr double kSuggestedMapSpacingMm = 2.0;
// The most voxels a refined map grid may have (two float maps: 384 MiB).
inline constexpr std::size_t kMaxRefinedVoxels = std::size_t{48} << 20;

// The factors for a CT on `grid`: k_a = ceil(s_a / map_spacing_mm) (at most 8), lowered until the
// refined grid fits kMaxRefinedVoxels; all 1 when map_spacing_mm <= 0 (the CT's own grid).
Refinement map_refinement(const Grid& grid, double map_spacing_mm);

bool is_refined(const Refinement& k);

// The grid refined by k: dims (n - 1) k + 1 (n where n == 1), spacing s / k, same placement.
Grid refined_grid(const Grid& grid, const Refinement& k);

// The factors that make `fine` the aligned refinement of `coarse` ({1,1,1}: the same grid), or
// {0,0,0} when it is not one (dims; spacing to 1e-6 relative, origin to 1e-4 mm and direction to
// 1e-6, as two files read back give them).
Refinement refinement_between(const Grid& coarse, const Grid& fine);

// The map on the refined grid, trilinear in the coarse nodes (exact at aligned nodes).
DistanceMap upsample_aligned(const DistanceMap& map, const Refinement& k, unsigned threads = 0);

}  // namespace palp
