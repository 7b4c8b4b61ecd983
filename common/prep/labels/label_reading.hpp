// Inside common/prep/labels: what the formats' readers share (the structures one label input
// builds, across its files) and the readers themselves.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "io/nrrd.hpp"
#include "prep/labels/label_classes.hpp"
#include "prep/labels/label_maps.hpp"
#include "prep/labels/label_volume.hpp"

namespace palp::labels {

// One class of a label file (a TotalSegmentator class, a Slicer segment): its name there and
// where it goes.
struct FileClass {
  std::string name;
  ClassMeaning meaning;
  std::string note;       // for the structure's source ("not a name palp knows: ..."), or empty
  std::size_t layer = 0;  // a Slicer segment's layer: segments in different layers may overlap
};

// The structures one label input builds, across its files (a folder has one per class). While
// the files are read, each CT voxel holds the id of its structure, one byte per voxel and layer;
// finish() cuts the masks from them: bone, arteries, veins on the CT's grid, each organ in its
// box. Memory: layers + unions + boxes, not a CT-sized mask per organ.
class LabelBuilder {
 public:
  LabelBuilder(const Grid& ct, std::string path);

  void set_format(std::string format) { format_ = std::move(format); }
  // Reads `volume`; lookup class i is classes[i]. Notes a grid that is not the CT's (once per
  // grid) and classes whose voxels all lie outside the CT (they are dropped). InputError when a
  // class lands on voxels another structure holds in its layer (overlapping files of a folder),
  // or past 255 structures.
  LabelCounts add(const LabelVolume& volume, const std::vector<FileClass>& classes,
                  const LabelLookup& lookup);
  void note(std::string text) { notes_.push_back(std::move(text)); }
  // The result. InputError when no labelled voxel lies on the CT.
  LabelMaps finish();

 private:
  struct Structure {
    ClassMeaning meaning;
    std::vector<std::string> classes;    // the file's names, in the order met
    std::vector<std::string> notes;      // the classes' notes, each once
    Index3 lo{0, 0, 0}, hi{-1, -1, -1};  // its box of CT voxels (empty: hi < lo)
    Mask* mask = nullptr;                // where finish() cuts it to
    std::uint64_t voxels = 0;            // CT voxels in its mask
    std::string skeleton;                // a vertebra's or rib's own name (bone kind), or empty
    std::uint8_t skeleton_value = 0;     // its value in skeleton_ (0: none)
  };
  std::size_t structure_of(const ClassMeaning& meaning, const std::string& skeleton,
                           const std::string& file);
  Mask& layer(std::size_t index);
  void check_overlaps(const LabelVolume& volume, const std::vector<FileClass>& classes,
                      const LabelCounts& counts) const;
  void find_boxes();
  void cut_masks();
  // Calls visit(structure, i, j, k) for every labelled CT voxel of every layer.
  template <class Visit>
  void for_each_labelled_voxel(Visit visit) {
    for (const Mask& ids : layers_) {
      if (ids.data.empty()) continue;
      std::size_t at = 0;
      for (std::int64_t k = 0; k < ct_.dims[2]; ++k)
        for (std::int64_t j = 0; j < ct_.dims[1]; ++j)
          for (std::int64_t i = 0; i < ct_.dims[0]; ++i, ++at)
            if (ids.data[at] != 0) visit(structures_[ids.data[at] - 1u], i, j, k);
    }
  }

  Grid ct_;
  std::string path_, format_;
  std::vector<Structure> structures_;
  std::vector<Mask> layers_;  // per layer, each CT voxel's structure id (index + 1) or 0
  Mask skeleton_;             // LabelMaps::skeleton, while cutting
  std::vector<std::string> notes_, resampled_grids_;
  bool resampled_ = false;
};

// "labels: PATH: message".
InputError labels_error(const std::string& path, const std::string& message);

// A NIfTI or plain NRRD label volume of TotalSegmentator's `total` task: named by its header
// extension, else by options.class_map.
using LabelTable = std::vector<std::pair<std::int64_t, std::string>>;  // (value, class name)
void read_total_multilabel(const LabelVolume& volume, const LabelTable& names,
                           const LabelMapOptions& options, LabelBuilder& out);
// TotalSegmentator's label table from a NIfTI's header extension; empty without one.
LabelTable nifti_label_table(const StoredImage& image);
// A directory of <class>.nii(.gz), one 0/1 mask per class of the `total` task.
void read_total_folder(const std::string& path, LabelBuilder& out);
// A 3D Slicer segmentation; `header` was read by read_nrrd_layered_header.
void read_slicer_segmentation(const NrrdLayeredImage& header, const std::string& path,
                              LabelBuilder& out);
// Whether a NRRD header carries Slicer's Segment<N>_... fields.
bool has_segment_fields(const NrrdLayeredImage& header);

}  // namespace palp::labels
