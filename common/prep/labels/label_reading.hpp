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
  std::string note;  // for the structure's source ("not a name palp knows: ..."), or empty
};

// The structures one label input builds, across its files (a folder has one per class).
class LabelBuilder {
 public:
  LabelBuilder(const Grid& ct, std::string path);

  void set_format(std::string format) { format_ = std::move(format); }
  // Reads `volume`; lookup class i is classes[i]. Notes a grid that is not the CT's (once per
  // grid) and classes whose voxels all lie outside the CT (they are dropped).
  LabelCounts add(const LabelVolume& volume, const std::vector<FileClass>& classes,
                  const LabelLookup& lookup);
  void note(std::string text) { notes_.push_back(std::move(text)); }
  // The result. InputError when no labelled voxel lies on the CT.
  LabelMaps finish();

 private:
  struct Structure {
    ClassMeaning meaning;
    Mask mask;
    std::vector<std::string> classes;  // the file's names, in the order met
    std::vector<std::string> notes;    // the classes' notes, each once
    std::uint64_t voxels = 0;          // CT voxels, counted per class (overlaps count twice)
  };
  std::size_t structure_of(const ClassMeaning& meaning);

  Grid ct_;
  std::string path_, format_;
  std::vector<Structure> structures_;
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
