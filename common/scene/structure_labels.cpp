// The structures of a prep directory as one label volume: see structure_labels.hpp.
#include "scene/structure_labels.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "prep/maps/map_refine.hpp"
#include "prep/prep.hpp"
#include "scene/prep_record.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;

struct Candidate {
  std::string name, kind, file;
};

// A plain .nii.gz file name (no directory, not hidden): prep.json is read, not trusted.
bool plain_mask_name(const std::string& file) {
  return !file.empty() && file.size() <= 255 && file.front() != '.' &&
         file.find('/') == std::string::npos && file.find('\\') == std::string::npos &&
         file.size() > 7 && file.compare(file.size() - 7, 7, ".nii.gz") == 0;
}

// prep.json's organs, by name: {"liver": {"kind": "organ", "files": ["liver.nii.gz", ...]}}.
std::vector<Candidate> recorded_organs(const fs::path& dir, std::string& note) {
  std::vector<Candidate> out;
  std::string why;
  const nlohmann::json json = scene_detail::read_prep_record(dir, &why);
  if (json.is_discarded()) {
    if (why != "no prep.json") note += why + ": no organs; ";
    return out;
  }
  const auto it = json.find("structures");
  if (it == json.end() || !it->is_object()) return out;
  for (const auto& [name, record] : it->items()) {
    if (!record.is_object() || record.value("kind", std::string()) != "organ") continue;
    std::string file = name + ".nii.gz";
    if (const auto files = record.find("files");
        files != record.end() && files->is_array() && !files->empty() && (*files)[0].is_string())
      file = (*files)[0].get<std::string>();
    if (name.empty() || name.size() > 64 || !plain_mask_name(file)) {
      note += "organ '" + name.substr(0, 64) + "': not a plain mask file name; ";
      continue;
    }
    out.push_back({name, "organ", file});
  }
  std::sort(out.begin(), out.end(),
            [](const Candidate& a, const Candidate& b) { return a.name < b.name; });
  return out;
}

// vessel, artery, then the organs; only those whose file is there.
std::vector<Candidate> candidates(const fs::path& dir, std::string& note) {
  std::vector<Candidate> all{{"vessel", "vessel", kVesselFile},
                             {"artery", "artery", "artery.nii.gz"}};
  for (Candidate& organ : recorded_organs(dir, note))
    if (organ.name != "vessel" && organ.name != "artery") all.push_back(std::move(organ));
  std::vector<Candidate> present;
  std::error_code ec;
  for (Candidate& c : all)
    if (fs::is_regular_file(dir / c.file, ec)) present.push_back(std::move(c));
  return present;
}

// The mask's voxel nearest to each node of `grid` (both placed alike: one refines the other).
void paint(const Mask& mask, Mask& labels, std::uint8_t label) {
  const Grid& g = labels.grid;
  const Index3& md = mask.grid.dims;
  std::array<std::vector<std::int64_t>, 3> index;
  for (int a = 0; a < 3; ++a) {
    index[a].resize(static_cast<std::size_t>(g.dims[a]));
    for (std::int64_t n = 0; n < g.dims[a]; ++n)
      index[a][static_cast<std::size_t>(n)] = std::clamp<std::int64_t>(
          std::llround(static_cast<double>(n) * g.spacing[a] / mask.grid.spacing[a]), 0, md[a] - 1);
  }
  std::size_t v = 0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j) {
      const std::size_t row =
          static_cast<std::size_t>(md[0] * (index[1][static_cast<std::size_t>(j)] +
                                            md[1] * index[2][static_cast<std::size_t>(k)]));
      for (std::int64_t i = 0; i < g.dims[0]; ++i, ++v)
        if (mask.data[row + static_cast<std::size_t>(index[0][static_cast<std::size_t>(i)])])
          labels.data[v] = label;
    }
}

}  // namespace

StructureLabels read_structure_labels(const std::string& prep_dir, const Grid& scene_grid) {
  StructureLabels out;
  const fs::path dir(prep_dir);
  std::vector<Candidate> list = candidates(dir, out.note);
  if (list.size() > kMaxStructureLabels) {
    out.note += std::to_string(list.size() - kMaxStructureLabels) + " organs over " +
                std::to_string(kMaxStructureLabels) + " structures left out; ";
    list.resize(kMaxStructureLabels);
  }
  // Read in label order.
  std::vector<std::pair<StructureLabel, Mask>> read;
  for (const Candidate& c : list) {
    Mask mask;
    try {
      mask = read_nifti_mask((dir / c.file).string());
    } catch (const Error& e) {
      out.note += c.file + " unreadable (" + e.what() + "); ";
      continue;
    }
    if (refinement_between(mask.grid, scene_grid)[0] == 0) {
      out.note += c.file + " is not on the maps' grid or one they refine; ";
      continue;
    }
    const auto label = static_cast<std::uint8_t>(read.size() + 1);
    read.push_back({StructureLabel{label, c.name, c.kind}, std::move(mask)});
    if (read.size() == 1) out.labels = Mask(read.front().second.grid, 0, "structure labels");
  }
  // Organs first, then the vessels, the artery last: each over what came before.
  const auto rank = [](const std::string& kind) { return kind == "artery" ? 2 : kind == "vessel"; };
  for (int r = 0; r <= 2; ++r)
    for (const auto& [structure, mask] : read)
      if (rank(structure.kind) == r) paint(mask, out.labels, structure.label);
  for (auto& [structure, mask] : read) out.structures.push_back(std::move(structure));
  if (!out.note.empty()) out.note.resize(out.note.size() - 2);  // the last "; "
  return out;
}

}  // namespace palp
