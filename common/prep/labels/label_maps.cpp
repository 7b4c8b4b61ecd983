// read_label_maps: which format a label input is, and the structures its readers build. See
// label_maps.hpp.
#include "prep/labels/label_maps.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <utility>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "io/nifti.hpp"
#include "prep/labels/label_reading.hpp"

namespace palp {
namespace labels {

InputError labels_error(const std::string& path, const std::string& message) {
  return InputError("labels: " + path + ": " + message);
}

namespace {

void add_once(std::vector<std::string>& list, const std::string& item) {
  if (std::find(list.begin(), list.end(), item) == list.end()) list.push_back(item);
}

std::string joined(const std::vector<std::string>& parts, const char* separator) {
  std::string out;
  for (const std::string& part : parts) out += (out.empty() ? "" : separator) + part;
  return out;
}

}  // namespace

LabelBuilder::LabelBuilder(const Grid& ct, std::string path) : ct_(ct), path_(std::move(path)) {}

std::size_t LabelBuilder::structure_of(const ClassMeaning& meaning) {
  for (std::size_t s = 0; s < structures_.size(); ++s)
    if (structures_[s].meaning.kind == meaning.kind &&
        structures_[s].meaning.structure == meaning.structure)
      return s;
  structures_.push_back({meaning, Mask{}, {}, {}, 0});
  return structures_.size() - 1;
}

LabelCounts LabelBuilder::add(const LabelVolume& volume, const std::vector<FileClass>& classes,
                              const LabelLookup& lookup) {
  std::vector<std::size_t> target;
  for (const FileClass& cls : classes) target.push_back(structure_of(cls.meaning));
  const MaskOfClass mask_of = [&](std::int32_t cls) -> Mask& {
    Structure& s = structures_[target[static_cast<std::size_t>(cls)]];
    if (s.mask.data.empty()) s.mask = Mask(ct_, 0, "labels: " + s.meaning.structure);
    return s.mask;
  };
  const LabelCounts counts = read_labels(volume, ct_, lookup, classes.size(), mask_of);
  if (counts.resampled) {
    resampled_ = true;
    const std::string from = describe_grid(volume.image.grid);
    if (std::find(resampled_grids_.begin(), resampled_grids_.end(), from) ==
        resampled_grids_.end()) {
      resampled_grids_.push_back(from);
      note(volume.name + ": resampled nearest-neighbour from " + from + " onto the CT's " +
           describe_grid(ct_));
    }
  }
  for (std::size_t i = 0; i < classes.size(); ++i) {
    Structure& s = structures_[target[i]];
    if (counts.on_ct[i] > 0) {
      add_once(s.classes, classes[i].name);
      if (!classes[i].note.empty()) add_once(s.notes, classes[i].note);
      s.voxels += counts.on_ct[i];
    } else if (counts.in_file[i] > 0) {
      note(classes[i].name + ": its " + std::to_string(counts.in_file[i]) + " voxels in " +
           volume.name + " all lie outside the CT: left out");
    }
  }
  return counts;
}

namespace {

void merge_into(Mask& into, const Mask& from, const Grid& ct) {
  if (from.data.empty()) return;
  if (into.data.empty()) into = Mask(ct, 0, "labels: vessel");
  for (std::size_t i = 0; i < from.data.size(); ++i) into.data[i] |= from.data[i];
}

}  // namespace

LabelMaps LabelBuilder::finish() {
  LabelMaps out;
  nlohmann::json structures = nlohmann::json::object();
  Mask vessel_unnamed;
  for (Structure& s : structures_) {
    if (s.mask.data.empty()) continue;
    const std::string& name = s.meaning.structure;
    structures[name] = {
        {"kind", kind_name(s.meaning.kind)}, {"classes", s.classes}, {"voxels", s.voxels}};
    switch (s.meaning.kind) {
      case Kind::bone:
        out.bone = std::move(s.mask);
        break;
      case Kind::artery:
        out.artery = std::move(s.mask);
        break;
      case Kind::vein:
        out.vein = std::move(s.mask);
        break;
      case Kind::vessel:
        vessel_unnamed = std::move(s.mask);
        break;
      case Kind::organ:
      case Kind::muscle:
        out.organs.push_back({name,
                              kind_name(s.meaning.kind),
                              std::move(s.mask),
                              {{"file", path_},
                               {"format", format_},
                               {"classes", s.classes},
                               {"resampled", resampled_},
                               {"note", joined(s.notes, "; ")}}});
        break;
    }
  }
  if (structures.empty()) throw labels_error(path_, "no labelled voxel lies inside the CT");
  merge_into(out.vessel, out.artery, ct_);
  merge_into(out.vessel, out.vein, ct_);
  merge_into(out.vessel, vessel_unnamed, ct_);
  std::sort(out.organs.begin(), out.organs.end(),
            [](const LabelledStructure& a, const LabelledStructure& b) { return a.name < b.name; });
  out.notes = notes_;
  out.source = {{"file", path_},
                {"format", format_},
                {"resampled", resampled_},
                {"structures", structures},
                {"notes", notes_}};
  return out;
}

}  // namespace labels

namespace {

bool ends_with_lower(const std::string& path, const std::string& suffix) {
  if (path.size() < suffix.size()) return false;
  for (std::size_t i = 0; i < suffix.size(); ++i) {
    const char c = path[path.size() - suffix.size() + i];
    if (std::tolower(static_cast<unsigned char>(c)) != suffix[i]) return false;
  }
  return true;
}

void read_nrrd_labels(const std::string& path, const LabelMapOptions& options,
                      labels::LabelBuilder& out) {
  const NrrdLayeredImage header = read_nrrd_layered_header(path);
  if (labels::has_segment_fields(header))
    return labels::read_slicer_segmentation(header, path, out);
  if (header.components != 1)
    throw labels::labels_error(path, "has " + std::to_string(header.components) +
                                         " layers but no Segment fields naming them");
  labels::read_total_multilabel({header.image, 1, path}, {}, options, out);
}

void read_nifti_labels(const std::string& path, const LabelMapOptions& options,
                       labels::LabelBuilder& out) {
  const StoredImage image = read_nifti_header(path);
  const auto names = labels::nifti_label_table(image);
  labels::read_total_multilabel({image, 1, path}, names, options, out);
}

}  // namespace

LabelMaps read_label_maps(const std::string& path, const Grid& ct_grid,
                          const LabelMapOptions& options) {
  if (!options.class_map.empty() && options.class_map != kTotalSegmentatorMap)
    throw UsageError("--labels-map: unknown class map \"" + options.class_map +
                     "\" (known: totalsegmentator)");
  validate_grid(ct_grid, "the CT");
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0)
    throw labels::labels_error(path,
                               errno == ENOENT || errno == ENOTDIR
                                   ? "no such file or directory"
                                   : std::string("cannot access (") + std::strerror(errno) + ")");
  labels::LabelBuilder out(ct_grid, path);
  try {
    if (S_ISDIR(info.st_mode)) {
      labels::read_total_folder(path, out);
    } else if (ends_with_lower(path, ".nrrd") || ends_with_lower(path, ".nhdr")) {
      read_nrrd_labels(path, options, out);
    } else if (is_nifti_name(path)) {
      read_nifti_labels(path, options, out);
    } else {
      throw labels::labels_error(path,
                                 "not a label map palp reads (TotalSegmentator's .nii/.nii.gz or "
                                 "folder of them, or a 3D Slicer .seg.nrrd)");
    }
  } catch (const InputError& e) {
    // The file readers' own messages ("PATH: truncated gzip stream") say where they come from.
    if (std::strncmp(e.what(), "labels: ", 8) == 0) throw;
    throw InputError(std::string("labels: ") + e.what());
  }
  return out.finish();
}

}  // namespace palp
