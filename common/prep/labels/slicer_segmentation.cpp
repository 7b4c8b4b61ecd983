// 3D Slicer segmentations (.seg.nrrd): a NRRD whose key:=value pairs describe the segments,
// Segment<N>_Name, _ID, _LabelValue, _Layer (with _Color, _Extent, _Tags, ... palp does not need).
// Segments that overlap lie in separate layers along a leading "list" axis. Files from Slicer
// before layers (4.10 and older) have neither LabelValue nor Layer: one segment per layer, value
// 1 (a single-layer file's segments all lie in layer 0).
#include <cctype>
#include <charconv>
#include <map>

#include "base/errors.hpp"
#include "prep/labels/label_reading.hpp"

namespace palp::labels {
namespace {

struct Segment {
  std::int64_t index = 0;  // N of Segment<N>_
  std::string name;
  std::int64_t value = 1;
  std::int64_t layer = 0;
};

// The N of a "Segment<N>_..." key, or -1.
std::int64_t segment_index(const std::string& key) {
  if (key.rfind("Segment", 0) != 0) return -1;
  const char* first = key.data() + 7;
  const char* last = key.data() + key.size();
  std::int64_t n = -1;
  const auto [ptr, ec] = std::from_chars(first, last, n);
  if (ec != std::errc() || ptr == first || ptr == last || *ptr != '_' || n < 0) return -1;
  return n;
}

std::int64_t integer_field(const std::map<std::string, std::string>& kv, const std::string& key,
                           std::int64_t fallback, const std::string& path) {
  const auto it = kv.find(key);
  if (it == kv.end()) return fallback;
  std::int64_t value = 0;
  const std::string& text = it->second;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || ptr != text.data() + text.size())
    throw labels_error(path, key + " \"" + text + "\" is not a whole number");
  return value;
}

std::vector<Segment> segments_of(const NrrdLayeredImage& header, const std::string& path) {
  const auto& kv = header.key_values;
  std::map<std::int64_t, Segment> segments;
  for (const auto& [key, value] : kv) {
    const std::int64_t n = segment_index(key);
    if (n >= 0) segments[n].index = n;
  }
  std::vector<Segment> out;
  for (auto& [n, s] : segments) {
    const std::string prefix = "Segment" + std::to_string(n) + "_";
    const auto name = kv.find(prefix + "Name");
    const auto id = kv.find(prefix + "ID");
    s.name = name != kv.end() ? name->second
             : id != kv.end() ? id->second
                              : "Segment" + std::to_string(n);
    s.value = integer_field(kv, prefix + "LabelValue", 1, path);
    s.layer = integer_field(kv, prefix + "Layer", header.components > 1 ? n : 0, path);
    if (s.value < 1 || s.value > static_cast<std::int64_t>(kMaxLabelValue))
      throw labels_error(path, "segment \"" + s.name + "\" has label value " +
                                   std::to_string(s.value) + " (labels are 1..65535)");
    if (s.layer < 0 || s.layer >= header.components)
      throw labels_error(path, "segment \"" + s.name + "\" is in layer " + std::to_string(s.layer) +
                                   ", but the file has " + std::to_string(header.components) +
                                   " layer(s)");
    out.push_back(s);
  }
  return out;
}

// Where a segment goes: by its name; an organ palp does not know keeps its name as a file name.
FileClass segment_class(const Segment& s, const std::string& path) {
  const NameMeaning named = classify_name(s.name);
  FileClass cls{s.name, named.meaning, {}, static_cast<std::size_t>(s.layer)};
  if (named.known) return cls;
  const auto file = structure_file_name(s.name);
  if (!file)
    throw labels_error(path, "segment \"" + s.name +
                                 "\" cannot become a file name (ASCII letters, digits, spaces, "
                                 "'-' and '_', at most 64; not body, ct, prep, structures or d_*)");
  cls.meaning.structure = *file;
  cls.note =
      "segment \"" + s.name + "\" is no name palp knows: kept as the organ \"" + *file + "\"";
  return cls;
}

}  // namespace

bool has_segment_fields(const NrrdLayeredImage& header) {
  for (const auto& entry : header.key_values)
    if (segment_index(entry.first) >= 0) return true;
  return false;
}

void read_slicer_segmentation(const NrrdLayeredImage& header, const std::string& path,
                              LabelBuilder& out) {
  out.set_format("slicer-seg-nrrd");
  const std::vector<Segment> segments = segments_of(header, path);
  LabelLookup lookup;
  lookup.table.assign(static_cast<std::size_t>(header.components), {LabelLookup::kBackground});
  std::vector<FileClass> classes;
  for (const Segment& s : segments) {
    auto& table = lookup.table[static_cast<std::size_t>(s.layer)];
    const auto value = static_cast<std::size_t>(s.value);
    if (table.size() <= value) table.resize(value + 1, LabelLookup::kUndefined);
    if (table[value] != LabelLookup::kUndefined)
      throw labels_error(
          path, "segments \"" + classes[static_cast<std::size_t>(table[value])].name + "\" and \"" +
                    s.name + "\" share the label value " + std::to_string(s.value) + " in layer " +
                    std::to_string(s.layer));
    table[value] = static_cast<std::int32_t>(classes.size());
    classes.push_back(segment_class(s, path));
    if (!classes.back().note.empty()) out.note(classes.back().note);
  }
  const LabelCounts counts = out.add({header.image, header.components, path}, classes, lookup);
  if (counts.undefined > 0)
    throw labels_error(path, "value " + std::to_string(counts.undefined_value) + " in layer " +
                                 std::to_string(counts.undefined_component) + " (" +
                                 std::to_string(counts.undefined) +
                                 " voxels) belongs to no segment");
  for (std::size_t i = 0; i < classes.size(); ++i)
    if (counts.in_file[i] == 0)
      throw labels_error(path, "segment \"" + classes[i].name + "\" (Segment" +
                                   std::to_string(segments[i].index) + ") is empty");
}

}  // namespace palp::labels
