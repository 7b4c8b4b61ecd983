// The structures a prep directory holds beyond skin and bone, as one label volume for the render
// volume palpd ships to its clients (palp.v1 SceneInfo.structures, VolumeChunk.labels):
//   vessel.nii.gz   every contrast-filled lumen (prep's vessel search, or a label map's vessels)
//   artery.nii.gz   the artery whose pulse the model renders (structure_layers.hpp)
//   <name>.nii.gz   each organ prep.json's "structures" records with kind "organ"
// Each is a uint8 0/1 mask on a grid the scene's maps lie on or refine (the CT's grid, or prep's
// map grid): one label each, 1.. in that order (vessel, artery, organs by name), at most
// kMaxStructureLabels. Where masks overlap the artery wins over the vessels, and both over an
// organ. Nothing here is read by the force model: it is what the clients draw.
#pragma once

#include <cstddef>
#include <cstdint>
#include <array>
#include <string>
#include <vector>

#include "base/volume.hpp"

namespace palp {

inline constexpr std::size_t kMaxStructureLabels = 64;  // labels fit a byte, with room to spare

struct StructureLabel {
  std::uint8_t label = 0;  // 1..kMaxStructureLabels
  std::string name;        // "vessel", "artery", "liver", ...
  std::string kind;        // "vessel", "artery" or "organ"
};

struct StructureLabels {
  Mask labels;  // the label of every voxel (0: none), on the first structure's grid
  std::vector<StructureLabel> structures;  // in label order
  std::string note;  // what was left out and why ("" when nothing was)
};

// The structures of `prep_dir` whose masks lie on a grid `scene_grid` (the maps' grid) equals or
// refines; none (structures empty, labels unallocated) when it has none. A mask that cannot be
// read, is not on such a grid, or is one too many is left out and said in `note` (the scene
// still loads: the structures are only drawn).
StructureLabels read_structure_labels(const std::string& prep_dir, const Grid& scene_grid);

// The label of the scene grid's voxel (i, j, k): the nearest node of the labels' grid, which
// `scene_grid` refines by `refine` (refinement_between(labels.grid, scene_grid)).
inline std::uint8_t label_at(const Mask& labels, const std::array<int, 3>& refine, std::int64_t i,
                             std::int64_t j, std::int64_t k) {
  const Index3& d = labels.grid.dims;
  const std::int64_t li = (i + refine[0] / 2) / refine[0], lj = (j + refine[1] / 2) / refine[1],
                     lk = (k + refine[2] / 2) / refine[2];
  if (li < 0 || lj < 0 || lk < 0 || li >= d[0] || lj >= d[1] || lk >= d[2]) return 0;
  return labels.data[static_cast<std::size_t>(li + d[0] * (lj + d[1] * lk))];
}

}  // namespace palp
