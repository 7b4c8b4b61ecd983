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

// A labelled vertebra or rib is a structure of its own (its voxels join the bone mask, and its
// own value the skeleton's labels); every other class of a kind and structure shares one.
std::size_t LabelBuilder::structure_of(const ClassMeaning& meaning, const std::string& skeleton,
                                       const std::string& file) {
  for (std::size_t s = 0; s < structures_.size(); ++s)
    if (structures_[s].meaning.kind == meaning.kind &&
        structures_[s].meaning.structure == meaning.structure &&
        structures_[s].skeleton == skeleton)
      return s;
  if (structures_.size() == 255)
    throw labels_error(file, "more than 255 structures (palp keeps one byte per voxel)");
  Structure added;
  added.meaning = meaning;
  added.skeleton = skeleton;
  structures_.push_back(std::move(added));
  return structures_.size() - 1;
}

Mask& LabelBuilder::layer(std::size_t index) {
  if (layers_.size() <= index) layers_.resize(index + 1);
  if (layers_[index].data.empty()) layers_[index] = Mask(ct_, 0, "labels: layer");
  return layers_[index];
}

LabelCounts LabelBuilder::add(const LabelVolume& volume, const std::vector<FileClass>& classes,
                              const LabelLookup& lookup) {
  std::vector<std::size_t> target;
  for (const FileClass& cls : classes) {
    std::string skeleton;
    if (cls.meaning.kind == Kind::bone) skeleton = skeleton_name(cls.name).value_or("");
    target.push_back(structure_of(cls.meaning, skeleton, volume.name));
  }
  const TargetOfClass target_of = [&](std::int32_t cls) {
    const auto c = static_cast<std::size_t>(cls);
    return ClassTarget{&layer(classes[c].layer), static_cast<std::uint8_t>(target[c] + 1)};
  };
  const LabelCounts counts = read_labels(volume, ct_, lookup, classes.size(), target_of);
  check_overlaps(volume, classes, counts);
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
    } else if (counts.in_file[i] > 0) {
      note(classes[i].name + ": its " + std::to_string(counts.in_file[i]) + " voxels in " +
           volume.name + " all lie outside the CT: left out");
    }
  }
  return counts;
}

void LabelBuilder::check_overlaps(const LabelVolume& volume, const std::vector<FileClass>& classes,
                                  const LabelCounts& counts) const {
  if (counts.overlaps == 0) return;
  const std::size_t at = counts.overlap_at;
  const auto i = static_cast<std::int64_t>(at) % ct_.dims[0];
  const auto j = static_cast<std::int64_t>(at) / ct_.dims[0] % ct_.dims[1];
  const auto k = static_cast<std::int64_t>(at) / ct_.dims[0] / ct_.dims[1];
  throw labels_error(volume.name,
                     classes[static_cast<std::size_t>(counts.overlap_class)].name + " overlaps " +
                         structures_[counts.overlap_previous - 1u].meaning.structure + " on " +
                         std::to_string(counts.overlaps) + " CT voxels, the first (" +
                         std::to_string(i) + ", " + std::to_string(j) + ", " + std::to_string(k) +
                         "): a voxel has one label");
}

// Each structure's box of CT voxels, over all layers.
void LabelBuilder::find_boxes() {
  for_each_labelled_voxel([&](Structure& s, std::int64_t i, std::int64_t j, std::int64_t k) {
    const Index3 p{i, j, k};
    const bool first = s.hi[0] < s.lo[0];
    for (int a = 0; a < 3; ++a) {
      s.lo[a] = first ? p[a] : std::min(s.lo[a], p[a]);
      s.hi[a] = first ? p[a] : std::max(s.hi[a], p[a]);
    }
  });
}

// Writes every structure's voxels into its mask (whose grid is the structure's box) and frees
// the layers.
void LabelBuilder::cut_masks() {
  for_each_labelled_voxel([&](Structure& s, std::int64_t i, std::int64_t j, std::int64_t k) {
    std::uint8_t& voxel = s.mask->at(i - s.lo[0], j - s.lo[1], k - s.lo[2]);
    s.voxels += voxel == 0 ? 1 : 0;
    voxel = 1;
    if (s.skeleton_value != 0) skeleton_.at(i, j, k) = s.skeleton_value;
  });
  layers_.clear();
}

namespace {

// The box [lo, hi] of `ct`'s voxels as a grid of its own, placed where those voxels are.
Grid box_grid(const Grid& ct, const Index3& lo, const Index3& hi) {
  Grid box = ct;
  for (int a = 0; a < 3; ++a) box.dims[a] = hi[a] - lo[a] + 1;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      box.world.origin[r] +=
          ct.world.direction[r * 3 + c] * ct.spacing[c] * static_cast<double>(lo[c]);
  return box;
}

void merge_into(Mask& into, const Mask& from, const Grid& ct) {
  if (from.data.empty()) return;
  if (into.data.empty()) into = Mask(ct, 0, "labels: vessel");
  for (std::size_t i = 0; i < from.data.size(); ++i) into.data[i] |= from.data[i];
}

}  // namespace

LabelMaps LabelBuilder::finish() {
  find_boxes();
  LabelMaps out;
  Mask vessel_unnamed;
  out.organs.reserve(structures_.size());  // the masks' addresses stay put
  for (Structure& s : structures_) {
    if (s.hi[0] < s.lo[0]) continue;
    switch (s.meaning.kind) {
      case Kind::bone:
        s.mask = &out.bone;
        break;
      case Kind::artery:
        s.mask = &out.artery;
        break;
      case Kind::vein:
        s.mask = &out.vein;
        break;
      case Kind::vessel:
        s.mask = &vessel_unnamed;
        break;
      case Kind::organ:
      case Kind::muscle:
        out.organs.push_back({s.meaning.structure,
                              kind_name(s.meaning.kind),
                              Mask(box_grid(ct_, s.lo, s.hi), 0, "labels: " + s.meaning.structure),
                              s.lo,
                              {{"file", path_},
                               {"format", format_},
                               {"classes", s.classes},
                               {"resampled", resampled_},
                               {"note", joined(s.notes, "; ")}}});
        s.mask = &out.organs.back().mask;
        continue;
    }
    if (s.mask->data.empty()) *s.mask = Mask(ct_, 0, "labels: " + s.meaning.structure);
    s.lo = {0, 0, 0};  // the unions lie on the whole CT grid
    if (!s.skeleton.empty()) {
      if (skeleton_.data.empty()) skeleton_ = Mask(ct_, 0, "labels: skeleton");
      out.skeleton_names.push_back(s.skeleton);
      s.skeleton_value = static_cast<std::uint8_t>(out.skeleton_names.size());
    }
  }
  cut_masks();
  out.skeleton = std::move(skeleton_);
  nlohmann::json structures = nlohmann::json::object();
  for (const Structure& s : structures_) {
    if (s.voxels == 0) continue;
    nlohmann::json& entry = structures[s.meaning.structure];
    if (entry.is_null()) {
      entry = {{"kind", kind_name(s.meaning.kind)},
               {"classes", nlohmann::json::array()},
               {"voxels", std::uint64_t{0}}};
    }
    for (const std::string& c : s.classes) entry["classes"].push_back(c);
    // The bone's structures share one mask: each counted only the voxels it added to it.
    entry["voxels"] = entry["voxels"].get<std::uint64_t>() + s.voxels;
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

Mask on_ct_grid(const LabelledStructure& structure, const Grid& ct_grid) {
  Mask out(ct_grid, 0, "labels: " + structure.name);
  const Grid& box = structure.mask.grid;
  const Index3& o = structure.offset;
  for (int a = 0; a < 3; ++a)
    if (o[a] < 0 || o[a] + box.dims[a] > ct_grid.dims[a])
      throw UsageError("labels: " + structure.name + "'s box does not fit the CT's grid");
  for (std::int64_t k = 0; k < box.dims[2]; ++k)
    for (std::int64_t j = 0; j < box.dims[1]; ++j)
      std::copy_n(
          structure.mask.data.begin() + static_cast<std::ptrdiff_t>(box.linear(0, j, k)),
          box.dims[0],
          out.data.begin() + static_cast<std::ptrdiff_t>(ct_grid.linear(o[0], o[1] + j, o[2] + k)));
  return out;
}

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
