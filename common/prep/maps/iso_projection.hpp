// Closest-point projection of a sub-voxel map onto the trilinear HU's own iso-surface.
//
// The sub-voxel map (prep/maps/subvoxel_distance.hpp) measures distance to tangent discs around
// points on the voxel edges. The points lie on the trilinearly interpolated CT's iso-surface
// (HU is linear along an edge), but the discs are planes with Sobel normals: between the points
// they leave the curved, trilinear iso-surface by up to ~0.1 mm on a 3 mm CT, and a force law read
// from the map at a constant true depth below that surface ripples by that much times its slope.
//
// For each grid node within `reach_mm` inside the surface or `outside_mm` outside it
// (-outside_mm <= map <= reach_mm: a pad pressed in reads the nodes around it, outside nodes
// only within a cell of the surface) the projection starts at the node's foot point along the
// map's own gradient, and descends on the distance over the trilinear HU's level set: Newton
// steps onto it, moves along its tangent plane towards the node kept where they bring the
// surface point nearer (the trilinear surface has creases at cell faces, where no tangent plane
// meets the closest-point condition). The node then takes the distance to that surface point,
// with the mask's sign, where the result is trustworthy:
//   - the point lies on the level set (|HU - iso| / |grad HU| below 0.005 mm);
//   - the cell holding the point is cut by the mask (so gas inside the body, or a table the
//     segmentation dropped, is never taken for the surface);
//   - the node's own HU lies on the mask's side of the level;
//   - the new distance differs from the map's by at most `max_change_mm` (the start was the
//     right sheet of the surface).
// Elsewhere the map keeps its value. The map may lie on the CT's grid refined by integer factors
// (prep/maps/map_refine.hpp): its nodes between the CT's take the upsampled map's sign (the HU's
// where the mask cuts their cell and the two disagree) and their HU by trilinear interpolation.
// Values are rounded to 1/1024 mm and clamped to +-clamp_mm, as the sub-voxel map is.
// The descent runs in one canonical storage order (the grid's axes nearest L, P and S, pointing
// along them), so a CT stored in another order (RAS, a sagittal series) gets the same values at
// the same patient positions, bit for bit given the same map.
#pragma once

#include <cstddef>

#include "base/volume.hpp"

namespace palp {

struct IsoProjectionStats {
  std::size_t visited = 0;    // nodes within reach
  std::size_t projected = 0;  // of those, nodes that took the projected distance
};

IsoProjectionStats project_onto_iso_surface(const CtVolume& ct, const Mask& mask, double iso_hu,
                                            double reach_mm, double outside_mm,
                                            double max_change_mm, double clamp_mm, DistanceMap& map,
                                            unsigned threads = 0);

// d_surf's projection as prep makes it, on the CT's grid or its aligned refinement: nodes within
// `reach_mm` inside the skin and one coarsest CT spacing c outside it, a change of at most c/4.
// Used by prep and by scene loading's in-memory refinement (scene/scene_maps.hpp), so both give
// the skin the same surface.
IsoProjectionStats project_skin_map(const CtVolume& ct, const Mask& body, double skin_hu,
                                    double reach_mm, double clamp_mm, DistanceMap& map,
                                    unsigned threads = 0);

// The distance from q (mm from voxel (0,0,0)'s centre) to the trilinear HU's level `iso_hu`,
// by the same descent from `start` (a point near the nearest surface point), which is moved to
// the surface point found. Negative where start cannot be put on the level set.
double distance_to_iso_surface(const CtVolume& ct, double iso_hu, const double q[3],
                               double start[3]);

}  // namespace palp
