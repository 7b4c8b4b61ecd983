// prep's structures beyond the body (see prep_structures.hpp).
#include "prep/prep_structures.hpp"

#include <algorithm>
#include <fstream>
#include <utility>

#include "base/parallel.hpp"
#include "io/phantom.hpp"
#include "prep/segment/components.hpp"

namespace palp {

namespace fs = std::filesystem;

// The smallest and largest value of a map, in parallel (the maps hold 10^8 voxels).
void value_range(const DistanceMap& map, float range[2], unsigned threads) {
  const auto n = static_cast<std::int64_t>(map.data.size());
  constexpr std::int64_t kGrain = std::int64_t{1} << 20;
  std::vector<std::pair<float, float>> parts(static_cast<std::size_t>((n + kGrain - 1) / kGrain));
  parallel_for_chunks(
      n, kGrain,
      [&](std::int64_t begin, std::int64_t end) {
        // Independent minima and maxima per lane, so the loop vectorizes (minmax_element does not).
        constexpr std::int64_t kLanes = 16;
        const float* v = map.data.data();
        float lo[kLanes], hi[kLanes];
        std::fill_n(lo, kLanes, v[begin]);
        std::fill_n(hi, kLanes, v[begin]);
        std::int64_t i = begin;
        for (; i + kLanes <= end; i += kLanes)
          for (std::int64_t l = 0; l < kLanes; ++l) {
            lo[l] = v[i + l] < lo[l] ? v[i + l] : lo[l];
            hi[l] = hi[l] < v[i + l] ? v[i + l] : hi[l];
          }
        for (; i < end; ++i) {
          lo[0] = std::min(lo[0], v[i]);
          hi[0] = std::max(hi[0], v[i]);
        }
        parts[static_cast<std::size_t>(begin / kGrain)] = {*std::min_element(lo, lo + kLanes),
                                                           *std::max_element(hi, hi + kLanes)};
      },
      threads);
  range[0] = range[1] = 0.0f;
  if (parts.empty()) return;
  range[0] = parts[0].first;
  range[1] = parts[0].second;
  for (const auto& [lo, hi] : parts) {
    range[0] = std::min(range[0], lo);
    range[1] = std::max(range[1], hi);
  }
}

std::string structure_file(const std::string& name) {
  return name + ".nii.gz";
}

std::string structure_distance_file(const std::string& name) {
  return "d_" + name + ".nii.gz";
}

std::vector<std::string> structure_files(const std::vector<LabelledStructure>& structures) {
  std::vector<std::string> files;
  for (const LabelledStructure& s : structures) {
    files.push_back(structure_file(s.name));
    files.push_back(structure_distance_file(s.name));
  }
  return files;
}

std::vector<std::string> recorded_outputs(const fs::path& dir) {
  std::ifstream in(dir / kPrepJsonFile);
  if (!in) return {};
  const nlohmann::json json = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded() || !json.is_object() || !json.contains("file_bytes") ||
      !json["file_bytes"].is_object())
    return {};
  std::vector<std::string> names;
  for (const auto& [name, bytes] : json["file_bytes"].items()) {
    if (name.empty() || name[0] == '.' || name.find('/') != std::string::npos ||
        !name.ends_with(".nii.gz"))
      continue;
    names.push_back(name);
  }
  return names;
}

void remove_stale_outputs(const fs::path& dir, const std::vector<std::string>& recorded,
                          const std::string& input, const std::string& labels_path) {
  for (const std::string& name : recorded) {
    if (name == kBodyFile || name == kBoneFile || name == kSurfaceDistanceFile ||
        name == kBoneDistanceFile || name == kCtFile)
      continue;
    const fs::path path = dir / name;
    std::error_code ec;
    if (fs::equivalent(path, input, ec)) continue;
    if (!labels_path.empty() && fs::equivalent(path, labels_path, ec)) continue;
    fs::remove(path, ec);
  }
}

nlohmann::json auto_structure_json(const char* kind, std::uint64_t voxels,
                                   std::vector<std::string> files) {
  return {{"kind", kind}, {"source", "auto"}, {"voxels", voxels}, {"files", std::move(files)}};
}

namespace {

// The label map's record of the structure `name` ("bone", "artery", ...): its classes and voxels.
nlohmann::json label_structure(const LabelMaps& maps, const char* name) {
  const nlohmann::json& structures = maps.source["structures"];
  return structures.contains(name) ? structures[name] : nlohmann::json();
}

nlohmann::json label_source(const LabelMaps& maps, nlohmann::json classes) {
  return {{"file", maps.source["file"]},
          {"format", maps.source["format"]},
          {"classes", std::move(classes)},
          {"resampled", maps.source["resampled"]}};
}

}  // namespace

nlohmann::json labelled_bone_json(const LabelMaps& maps, std::uint64_t voxels) {
  return {{"kind", "bone"},
          {"source", label_source(maps, label_structure(maps, "bone")["classes"])},
          {"voxels", voxels},
          {"files", {kBoneFile, kBoneDistanceFile}}};
}

nlohmann::json labelled_vessel_json(const LabelMaps& maps, std::uint64_t voxels) {
  nlohmann::json classes = nlohmann::json::array();
  nlohmann::json split = nlohmann::json::object();
  for (const char* kind : {"artery", "vein", "vessel"}) {
    const nlohmann::json part = label_structure(maps, kind);
    if (part.is_null()) continue;
    for (const auto& c : part["classes"]) classes.push_back(c);
    split[kind] = {{"classes", part["classes"]}, {"voxels", part["voxels"]}};
  }
  nlohmann::json source = label_source(maps, std::move(classes));
  source["split"] = split;
  return {{"kind", "vessel"},
          {"source", source},
          {"voxels", voxels},
          {"files", {kVesselFile, kVesselDistanceFile}}};
}

namespace {

// The voxels of `full` (a mask on the CT's grid) as a structure cut to their box; none when empty.
std::optional<LabelledStructure> boxed_structure(const std::string& name, const char* kind,
                                                 const Mask& full, nlohmann::json source) {
  const Grid& g = full.grid;
  Index3 lo = g.dims, hi{-1, -1, -1};
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        if (!full.data[g.linear(i, j, k)]) continue;
        const Index3 p{i, j, k};
        for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
      }
  if (hi[0] < 0) return std::nullopt;
  Grid box = g;
  for (int a = 0; a < 3; ++a) box.dims[a] = hi[a] - lo[a] + 1;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      box.world.origin[r] +=
          g.world.direction[r * 3 + c] * g.spacing[c] * static_cast<double>(lo[c]);
  LabelledStructure s{name, kind, Mask(box, 0, name), lo, std::move(source)};
  for (std::int64_t k = 0; k < box.dims[2]; ++k)
    for (std::int64_t j = 0; j < box.dims[1]; ++j)
      std::copy_n(
          full.data.begin() + static_cast<std::ptrdiff_t>(g.linear(lo[0], lo[1] + j, lo[2] + k)),
          box.dims[0], s.mask.data.begin() + static_cast<std::ptrdiff_t>(box.linear(0, j, k)));
  return s;
}

}  // namespace

std::optional<LabelledStructure> labelled_artery(LabelMaps& maps) {
  if (maps.artery.data.empty()) return std::nullopt;
  std::optional<LabelledStructure> artery =
      boxed_structure("artery", "artery", maps.artery,
                      label_source(maps, label_structure(maps, "artery")["classes"]));
  maps.artery = Mask{};
  return artery;
}

bool phantom_draws_structures(const std::string& input) {
  const std::string prefix = "phantom:";
  if (input.rfind(prefix, 0) != 0) return false;
  return parse_phantom_spec(input.substr(prefix.size())).options.structures;
}

CtVolume read_ct_with_truth(const std::string& input, std::vector<LabelledStructure>* truth) {
  if (truth == nullptr || !phantom_draws_structures(input)) return read_ct(input);
  const PhantomSpec spec = parse_phantom_spec(input.substr(std::string("phantom:").size()));
  PhantomTruth drawn;
  CtVolume ct = make_phantom(spec.name, spec.options, &drawn);
  const auto add = [&](const char* name, const char* kind, Mask& mask) {
    nlohmann::json source = {{"format", "phantom-truth"}, {"phantom", input}, {"truth", name}};
    if (auto s = boxed_structure(name, kind, mask, std::move(source)))
      truth->push_back(std::move(*s));
    mask = Mask{};
  };
  add("artery", "artery", drawn.artery);
  add("liver", "organ", drawn.liver);
  return ct;
}

void write_labelled_structures(std::vector<LabelledStructure>& structures, const Grid& ct_grid,
                               const DistanceParams& distance, const Refinement& refine,
                               const fs::path& dir, DistanceMap& map, nlohmann::json& records,
                               std::vector<std::string>& files) {
  for (LabelledStructure& s : structures) {
    const std::string file = structure_file(s.name);
    const std::string distance_file = structure_distance_file(s.name);
    std::uint64_t voxels = 0;
    {
      const Mask mask = on_ct_grid(s, ct_grid);
      s.mask = Mask{};  // its box: no longer needed
      voxels = segmentation::count_nonzero(mask);
      write_atomically(dir / file, mask);
      signed_distance(mask, distance, map);
    }
    if (is_refined(refine)) map = upsample_aligned(map, refine, distance.threads);
    float range[2];
    value_range(map, range, distance.threads);
    write_atomically(dir / distance_file, map, range[0], range[1]);
    records[s.name] = {{"kind", s.kind},
                       {"source", s.source},
                       {"voxels", voxels},
                       {"files", {file, distance_file}},
                       {"distance_range_mm", {range[0], range[1]}}};
    files.push_back(file);
    files.push_back(distance_file);
  }
}

namespace {

// "auto", "phantom truth INPUT", or "labels FILE (its classes: up to three by name, else how
// many)".
std::string describe_source(const nlohmann::json& source) {
  if (source.is_string()) return source.get<std::string>();
  if (source.contains("phantom")) return "phantom truth " + source.value("phantom", std::string());
  std::string text = "labels " + source.value("file", std::string());
  const nlohmann::json& classes = source.contains("classes") ? source["classes"] : nlohmann::json();
  if (!classes.is_array() || classes.empty()) return text;
  std::string list;
  if (classes.size() > 3) {
    list = std::to_string(classes.size()) + " classes";
  } else {
    for (const auto& c : classes) list += (list.empty() ? "" : ", ") + c.get<std::string>();
  }
  return text + " (" + list + ")";
}

}  // namespace

std::vector<PrepStructure> structure_summaries(const nlohmann::json& records) {
  std::vector<PrepStructure> out;
  if (!records.is_object()) return out;
  for (const auto& [name, record] : records.items()) {
    if (!record.is_object()) continue;
    out.push_back(
        {name, record.value("kind", std::string()), record.value("voxels", std::uint64_t{0}),
         describe_source(record.contains("source") ? record["source"] : nlohmann::json("auto"))});
  }
  auto rank = [](const PrepStructure& s) {
    return s.name == "bone" ? 0 : s.name == "vessel" ? 1 : s.name == "artery" ? 2 : 3;
  };
  std::stable_sort(out.begin(), out.end(), [&](const PrepStructure& a, const PrepStructure& b) {
    return rank(a) < rank(b);
  });
  return out;
}

}  // namespace palp
