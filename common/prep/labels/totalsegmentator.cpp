// TotalSegmentator's outputs of its `total` task: the multi-label NIfTI (`--ml`), named by the
// label table TotalSegmentator writes into the NIfTI header extension, and the folder of one
// 0/1 mask per class.
//
// The extension (TotalSegmentator >= 1.5, totalsegmentator/nifti_ext_header.py,
// add_label_map_to_nifti): one NIfTI-1 extension, ecode 0, holding CaretExtension XML whose
// LabelTable has one <Label Key="id" ...><![CDATA[name]]></Label> per class.
#include <algorithm>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>

#include "base/errors.hpp"
#include "io/gzip.hpp"
#include "io/nifti.hpp"
#include "prep/labels/label_reading.hpp"

namespace palp::labels {
namespace {

constexpr std::size_t kNiftiHeaderBytes = 348;
// The header extensions palp reads: TotalSegmentator's table takes about 20 kB for 117 classes.
constexpr std::uint64_t kMaxExtensionBytes = std::uint64_t{4} << 20;

std::string trimmed(std::string_view s) {
  const auto space = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; };
  while (!s.empty() && space(s.front())) s.remove_prefix(1);
  while (!s.empty() && space(s.back())) s.remove_suffix(1);
  return std::string(s);
}

// An XML text node: CDATA as it is, else with the five predefined entities decoded.
std::string xml_text(std::string_view text) {
  const std::string t = trimmed(text);
  if (t.rfind("<![CDATA[", 0) == 0 && t.size() >= 12 && t.compare(t.size() - 3, 3, "]]>") == 0)
    return t.substr(9, t.size() - 12);
  static const std::pair<std::string_view, char> kEntities[] = {
      {"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
  std::string out;
  for (std::size_t i = 0; i < t.size(); ++i) {
    bool decoded = false;
    for (const auto& [entity, c] : kEntities) {
      if (t.compare(i, entity.size(), entity) == 0) {
        out += c;
        i += entity.size() - 1;
        decoded = true;
        break;
      }
    }
    if (!decoded) out += t[i];
  }
  return out;
}

// The <Label Key="..."> entries of a CaretExtension's LabelTable.
LabelTable caret_labels(std::string_view xml) {
  LabelTable table;
  std::size_t at = 0;
  while ((at = xml.find("<Label", at)) != std::string_view::npos) {
    at += 6;
    if (at >= xml.size() || (xml[at] != ' ' && xml[at] != '\t' && xml[at] != '\n')) continue;
    const std::size_t close = xml.find('>', at);
    const std::size_t key = xml.find("Key=\"", at);
    const std::size_t end = xml.find("</Label>", close);
    if (close == std::string_view::npos || end == std::string_view::npos) break;
    if (key == std::string_view::npos || key > close) continue;
    std::int64_t id = 0;
    const char* first = xml.data() + key + 5;
    const auto [ptr, ec] = std::from_chars(first, xml.data() + close, id);
    if (ec == std::errc() && *ptr == '"')
      table.emplace_back(id, xml_text(xml.substr(close + 1, end - close - 1)));
    at = end;
  }
  return table;
}

template <class T>
T read_value(const std::vector<std::uint8_t>& bytes, std::size_t at, bool swapped) {
  T value;
  std::memcpy(&value, bytes.data() + at, sizeof value);
  return swapped ? byte_swapped(value) : value;
}

}  // namespace

LabelTable nifti_label_table(const StoredImage& image) {
  const StoredVoxels& v = image.voxels;
  const std::uint64_t end = std::min(v.skip, kNiftiHeaderBytes + kMaxExtensionBytes);
  if (end <= kNiftiHeaderBytes + 4) return {};
  std::vector<std::uint8_t> head(static_cast<std::size_t>(end));
  DecodedReader reader(v.path, 0, v.compression);
  head.resize(reader.read(head.data(), head.size()));
  if (head.size() <= kNiftiHeaderBytes + 4 || head[kNiftiHeaderBytes] == 0) return {};
  const bool swapped = v.big_endian != kHostIsBigEndian;
  std::size_t at = kNiftiHeaderBytes + 4;
  while (at + 8 <= head.size()) {
    const auto esize = read_value<std::int32_t>(head, at, swapped);
    if (esize < 8 || static_cast<std::uint64_t>(esize) > head.size() - at) break;
    const std::string_view content(reinterpret_cast<const char*>(head.data()) + at + 8,
                                   static_cast<std::size_t>(esize) - 8);
    if (content.find("<CaretExtension") != std::string_view::npos) {
      LabelTable table = caret_labels(content);
      if (!table.empty()) return table;
    }
    at += static_cast<std::size_t>(esize);
  }
  return {};
}

namespace {

// The lookup and classes of a label table whose names must all be the `total` task's.
void named_classes(const LabelVolume& volume, const LabelTable& names,
                   std::vector<FileClass>& classes, LabelLookup& lookup) {
  std::vector<std::int32_t>& table = lookup.table[0];
  for (const auto& [id, name] : names) {
    if (id == 0) continue;  // background, if a table names it
    const TotalClass* cls = find_total_class(name);
    if (!cls)
      throw labels_error(volume.name, "class " + std::to_string(id) + " \"" + name +
                                          "\" is not a class of TotalSegmentator's total task "
                                          "(v2): palp reads that task's labels");
    if (id < 0 || id > static_cast<std::int64_t>(kMaxLabelValue))
      throw labels_error(volume.name, "its label table numbers \"" + name + "\" " +
                                          std::to_string(id) + " (labels are 1..65535)");
    const auto value = static_cast<std::size_t>(id);
    if (table.size() <= value) table.resize(value + 1, LabelLookup::kUndefined);
    if (table[value] != LabelLookup::kUndefined)
      throw labels_error(volume.name,
                         "its label table names value " + std::to_string(id) + " twice");
    table[value] = static_cast<std::int32_t>(classes.size());
    classes.push_back({name, meaning_of(*cls), {}});
  }
}

bool numbered_as_total(const LabelTable& names) {
  return std::all_of(names.begin(), names.end(), [](const auto& entry) {
    const TotalClass* cls = find_total_class(entry.second);
    return entry.first == 0 || (cls && cls->id == entry.first);
  });
}

}  // namespace

void read_total_multilabel(const LabelVolume& volume, const LabelTable& names,
                           const LabelMapOptions& options, LabelBuilder& out) {
  out.set_format("totalsegmentator-multilabel");
  std::vector<FileClass> classes;
  LabelLookup lookup{{{LabelLookup::kBackground}}};
  if (!names.empty()) {
    named_classes(volume, names, classes, lookup);
    if (!numbered_as_total(names))
      out.note(volume.name +
               ": its label table numbers the classes otherwise than TotalSegmentator "
               "v2.2 and later (an older version?): read by its own names");
  } else if (options.class_map == kTotalSegmentatorMap) {
    LabelTable total;
    for (const TotalClass& cls : total_classes()) total.emplace_back(cls.id, cls.name);
    named_classes(volume, total, classes, lookup);
  } else {
    throw labels_error(volume.name,
                       "names no classes (no TotalSegmentator label table in its header); if it "
                       "is TotalSegmentator's total task (v2), give --labels-map totalsegmentator");
  }
  const LabelCounts counts = out.add(volume, classes, lookup);
  if (counts.undefined > 0 && names.empty())
    throw labels_error(volume.name, "values up to " + std::to_string(counts.max_value) +
                                        ", but TotalSegmentator's total map (--labels-map "
                                        "totalsegmentator) has " +
                                        std::to_string(kTotalClassCount) +
                                        " classes: not its total task");
  if (counts.undefined > 0)
    throw labels_error(volume.name, "value " + std::to_string(counts.undefined_value) + " (" +
                                        std::to_string(counts.undefined) +
                                        " voxels) has no name in its label table");
  if (counts.labelled_in_file == 0)
    throw InputError("labels: " + volume.name + " is empty (no voxel labelled)");
}

namespace {

// "liver.nii.gz" -> "liver"; empty for a name that is not NIfTI.
std::string nifti_stem(const std::string& file) {
  for (const std::string suffix : {".nii.gz", ".nii"})
    if (file.size() > suffix.size() &&
        file.compare(file.size() - suffix.size(), suffix.size(), suffix) == 0)
      return file.substr(0, file.size() - suffix.size());
  return {};
}

// The folder's NIfTI files by class (all the `total` task's), and the other files' names.
std::map<std::string, std::string> class_files(const std::string& dir,
                                               std::vector<std::string>& others) {
  std::map<std::string, std::string> files;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    const std::string file = entry.path().filename().string();
    const std::string stem = nifti_stem(file);
    if (stem.empty() || !entry.is_regular_file()) {
      others.push_back(file);
      continue;
    }
    if (!find_total_class(stem))
      throw labels_error(entry.path().string(),
                         "\"" + stem +
                             "\" is not a class of TotalSegmentator's total task (v2); "
                             "move the file out of the folder");
    if (!files.emplace(stem, entry.path().string()).second)
      throw labels_error(dir, "two files for the class \"" + stem + "\"");
  }
  if (ec) throw labels_error(dir, "cannot list the folder (" + ec.message() + ")");
  if (files.empty())
    throw labels_error(dir, "holds no <class>.nii.gz of TotalSegmentator's total task");
  std::sort(others.begin(), others.end());
  return files;
}

}  // namespace

void read_total_folder(const std::string& dir, LabelBuilder& out) {
  out.set_format("totalsegmentator-folder");
  std::vector<std::string> others;
  const std::map<std::string, std::string> files = class_files(dir, others);
  // TotalSegmentator writes every class of its task, in the scan or not: in the whole task's
  // folder an empty file is expected. A subset (--roi_subset) names what the user asked for.
  const bool whole_task = files.size() == static_cast<std::size_t>(kTotalClassCount);
  std::size_t empty = 0;
  for (const auto& [name, path] : files) {
    const LabelVolume volume{read_nifti_header(path), 1, path};
    const LabelLookup lookup{{{LabelLookup::kBackground, 0}}};
    const LabelCounts counts =
        out.add(volume, {{name, meaning_of(*find_total_class(name)), {}}}, lookup);
    if (counts.undefined > 0)
      throw labels_error(
          path, "holds the value " + std::to_string(counts.undefined_value) + ": not a 0/1 mask");
    if (counts.labelled_in_file > 0) continue;
    if (!whole_task)
      throw InputError("labels: " + path + " is empty (delete it to go on without " + name + ")");
    ++empty;
  }
  if (empty > 0)
    out.note(std::to_string(empty) + " of the " + std::to_string(files.size()) +
             " class files are empty (the classes are not in the scan)");
  if (!others.empty()) {
    std::string list;
    for (const std::string& other : others) list += (list.empty() ? "" : ", ") + other;
    out.note("ignored what is not a <class>.nii.gz: " + list);
  }
}

}  // namespace palp::labels
