// run_prep with a lab's label map (issue 38): a small sphere CT and a TotalSegmentator `total`
// output built here, as its multi-label NIfTI (ids from TotalSegmentator's map_to_binary.py,
// class_map["total"], as literals) and as its folder of one mask per class. The bone written is
// the union of the bone classes voxel for voxel, the vessel the arteries' and veins', the artery
// the arteries' alone, each organ a <name>.nii.gz and d_<name>.nii.gz; prep.json says where each
// came from; the cache follows the label file's bytes; a label map that does not fit the CT leaves
// nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "io/nifti.hpp"
#include "io/phantom.hpp"
#include "prep/labels/label_maps.hpp"
#include "prep/prep.hpp"
#include "support/io_test_util.hpp"
#include "support/label_files.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

// A box of CT voxels [lo, hi) per axis.
struct Box {
  Index3 lo, hi;
  std::uint64_t voxels() const {
    return static_cast<std::uint64_t>((hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]));
  }
};

struct Labelled {
  int id;            // TotalSegmentator total task's id
  std::string name;  // its class name
  Box box;
};

// On a 44^3 CT of 2 mm voxels.
const Labelled kLiver{5, "liver", {{8, 8, 8}, {18, 18, 18}}};
const Labelled kSpleen{1, "spleen", {{30, 30, 30}, {34, 34, 34}}};
const Labelled kVertebra{31, "vertebrae_L1", {{24, 24, 10}, {30, 30, 16}}};
const Labelled kRib{92, "rib_left_1", {{24, 10, 10}, {30, 14, 16}}};
const Labelled kAorta{52, "aorta", {{8, 26, 20}, {12, 30, 30}}};
const Labelled kCava{63, "inferior_vena_cava", {{14, 26, 20}, {18, 30, 30}}};
const std::vector<Labelled> kAbdomen = {kLiver, kVertebra, kRib, kAorta, kCava};

void fill(const Grid& grid, const Box& box, std::uint8_t value, std::vector<std::uint8_t>& out) {
  for (std::int64_t k = box.lo[2]; k < box.hi[2]; ++k)
    for (std::int64_t j = box.lo[1]; j < box.hi[1]; ++j)
      for (std::int64_t i = box.lo[0]; i < box.hi[0]; ++i) out[grid.linear(i, j, k)] = value;
}

std::vector<std::uint8_t> labels_of(const Grid& grid, const std::vector<Labelled>& classes) {
  std::vector<std::uint8_t> values(grid.voxel_count(), 0);
  for (const Labelled& c : classes) fill(grid, c.box, static_cast<std::uint8_t>(c.id), values);
  return values;
}

std::vector<std::uint8_t> mask_of(const Grid& grid, const std::vector<Labelled>& classes) {
  std::vector<std::uint8_t> values(grid.voxel_count(), 0);
  for (const Labelled& c : classes) fill(grid, c.box, 1, values);
  return values;
}

nlohmann::json read_json(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

std::set<std::string> names(const nlohmann::json& list) {
  std::set<std::string> out;
  for (const auto& item : list) out.insert(item.get<std::string>());
  return out;
}

std::set<std::string> files_in(const fs::path& dir) {
  std::set<std::string> out;
  for (const auto& entry : fs::directory_iterator(dir)) out.insert(entry.path().filename());
  return out;
}

class PrepLabels : public ::testing::Test {
 protected:
  void SetUp() override {
    PhantomOptions options;
    options.dims = Index3{44, 44, 44};
    options.spacing = Vec3{2.0, 2.0, 2.0};
    CtVolume ct = make_phantom("sphere", options);
    ct.grid.world.origin = {-40.0, 12.0, 100.0};
    input_ = dir_.file("ct.nii.gz");
    write_nifti(input_, ct);
    grid_ = read_ct(input_).grid;  // the placement as the file holds it
    params_.distance.threads = 2;
    params_.map_spacing_mm = 0.0;  // the CT's own grid
    params_.labels_map = kTotalSegmentatorMap;
  }
  // The multi-label NIfTI TotalSegmentator writes with --ml (here without its header table).
  std::string write_multilabel(const std::string& name, const std::vector<Labelled>& classes) {
    const std::string path = dir_.file(name);
    testing::write_label_nifti(path, grid_, labels_of(grid_, classes));
    return path;
  }
  // Its folder: one 0/1 <class>.nii.gz per class.
  std::string write_folder(const std::string& name, const std::vector<Labelled>& classes) {
    const fs::path folder = dir_.path() / name;
    fs::create_directories(folder);
    for (const Labelled& c : classes)
      testing::write_label_nifti((folder / (c.name + ".nii.gz")).string(), grid_,
                                 mask_of(grid_, {c}));
    return folder.string();
  }
  fs::path out() const { return dir_.path() / "out"; }
  PrepResult prep(const std::string& labels) {
    params_.labels_path = labels;
    return run_prep(input_, out().string(), params_);
  }
  void expect_abdomen_outputs(const std::string& labels, const std::string& format);

  TempDir dir_;
  std::string input_;
  Grid grid_;
  PrepParams params_;
};

float at(const DistanceMap& map, std::int64_t i, std::int64_t j, std::int64_t k) {
  return map.data[map.grid.linear(i, j, k)];
}

void PrepLabels::expect_abdomen_outputs(const std::string& labels, const std::string& format) {
  // The bone is the union of the bone classes, the vessel the artery's and the vein's, voxel for
  // voxel (issue 38: Dice >= 0.99; equal here).
  const Mask bone = read_nifti_mask((out() / kBoneFile).string());
  EXPECT_EQ(bone.grid.dims, grid_.dims);
  EXPECT_EQ(bone.data, mask_of(grid_, {kVertebra, kRib}));
  EXPECT_EQ(read_nifti_mask((out() / kVesselFile).string()).data, mask_of(grid_, {kAorta, kCava}));
  const Mask liver = read_nifti_mask((out() / "liver.nii.gz").string());
  EXPECT_EQ(liver.grid.dims, grid_.dims);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(liver.grid.world.origin[a], grid_.world.origin[a], 1e-4);
  EXPECT_EQ(liver.data, mask_of(grid_, {kLiver}));
  // d = distance to the nearest voxel centre across the surface - h/2 (h = 2 mm), positive inside.
  const DistanceMap d_liver = read_nifti_float((out() / "d_liver.nii.gz").string());
  EXPECT_NEAR(at(d_liver, 13, 13, 13), 5 * 2.0 - 1.0, 1e-4);  // 5 voxels from (18, 13, 13)
  EXPECT_NEAR(at(d_liver, 8, 13, 13), 1 * 2.0 - 1.0, 1e-4);   // on its face
  EXPECT_NEAR(at(d_liver, 4, 13, 13), -(4 * 2.0 - 1.0), 1e-4);
  EXPECT_NEAR(at(d_liver, 5, 5, 13), -(std::sqrt(18.0) * 2.0 - 1.0), 1e-4);  // from (8, 8, 13)
  // The arteries alone as a structure of their own, written as an organ is (issue 39: the force
  // model's artery layer): the aorta's box; 2 voxels from its faces at its middle.
  EXPECT_EQ(read_nifti_mask((out() / "artery.nii.gz").string()).data, mask_of(grid_, {kAorta}));
  const DistanceMap d_artery = read_nifti_float((out() / "d_artery.nii.gz").string());
  EXPECT_EQ(d_artery.grid.dims, grid_.dims);
  EXPECT_NEAR(at(d_artery, 10, 28, 25), 2 * 2.0 - 1.0, 1e-4);     // 2 voxels from (12, 28, 25)
  EXPECT_NEAR(at(d_artery, 15, 28, 25), -(4 * 2.0 - 1.0), 1e-4);  // in the cava, 4 from (11, ...)
  const DistanceMap d_vessel = read_nifti_float((out() / kVesselDistanceFile).string());
  EXPECT_GT(at(d_vessel, 10, 28, 25), 0.0f);
  EXPECT_LT(at(d_vessel, 13, 28, 25), 0.0f);  // between the aorta and the cava
  const DistanceMap d_bone = read_nifti_float((out() / kBoneDistanceFile).string());
  EXPECT_GT(at(d_bone, 27, 27, 13), 0.0f);
  EXPECT_LT(at(d_bone, 27, 20, 13), 0.0f);  // between the vertebra and the rib

  const nlohmann::json json = read_json(out() / kPrepJsonFile);
  const nlohmann::json& s = json["structures"];
  EXPECT_EQ(s["bone"]["source"]["file"], labels);
  EXPECT_EQ(s["bone"]["source"]["format"], format);
  EXPECT_EQ(names(s["bone"]["source"]["classes"]),
            (std::set<std::string>{"vertebrae_L1", "rib_left_1"}));
  EXPECT_EQ(s["bone"]["voxels"], kVertebra.box.voxels() + kRib.box.voxels());
  EXPECT_EQ(names(s["vessel"]["source"]["classes"]),
            (std::set<std::string>{"aorta", "inferior_vena_cava"}));
  EXPECT_EQ(s["vessel"]["source"]["split"]["artery"]["voxels"], kAorta.box.voxels());
  EXPECT_EQ(s["vessel"]["source"]["split"]["vein"]["voxels"], kCava.box.voxels());
  EXPECT_EQ(s["artery"]["kind"], "artery");
  EXPECT_EQ(s["artery"]["source"]["file"], labels);
  EXPECT_EQ(s["artery"]["source"]["classes"], nlohmann::json({"aorta"}));
  EXPECT_EQ(s["artery"]["voxels"], kAorta.box.voxels());
  EXPECT_EQ(s["artery"]["files"], nlohmann::json({"artery.nii.gz", "d_artery.nii.gz"}));
  EXPECT_EQ(s["liver"]["kind"], "organ");
  EXPECT_EQ(s["liver"]["source"]["file"], labels);
  EXPECT_EQ(s["liver"]["source"]["classes"], nlohmann::json({"liver"}));
  EXPECT_EQ(s["liver"]["voxels"], 1000);
  EXPECT_EQ(json["voxels"]["bone"], kVertebra.box.voxels() + kRib.box.voxels());
  EXPECT_EQ(json["voxels"]["vessel"], kAorta.box.voxels() + kCava.box.voxels());
  // file_bytes: every file written, at its size; nothing else is left in the directory.
  std::set<std::string> recorded;
  for (const auto& [name, bytes] : json["file_bytes"].items()) {
    recorded.insert(name);
    EXPECT_EQ(bytes, fs::file_size(out() / name)) << name;
  }
  EXPECT_EQ(recorded,
            (std::set<std::string>{"body.nii.gz", "bone.nii.gz", "d_surf.nii.gz", "d_bone.nii.gz",
                                   "ct.nii.gz", "vessel.nii.gz", "d_vessel.nii.gz", "artery.nii.gz",
                                   "d_artery.nii.gz", "liver.nii.gz", "d_liver.nii.gz",
                                   kSkeletonLabelsFile}));
  // The labelled vertebra and rib, each its own value, named in prep.json (landmarks read them).
  const nlohmann::json& table = json["skeleton_labels"];
  EXPECT_EQ(table["file"], kSkeletonLabelsFile);
  EXPECT_EQ(table["source"], labels);
  ASSERT_EQ(table["labels"].size(), 2u);
  // (read_nifti_mask makes any value 1: read as floats, the values as they are)
  const DistanceMap skeleton = read_nifti_float((out() / kSkeletonLabelsFile).string());
  ASSERT_EQ(skeleton.grid.dims, grid_.dims);
  for (const auto& [value, name] : table["labels"].items()) {
    const Labelled& c = name == "vertebrae_L1" ? kVertebra : kRib;
    EXPECT_TRUE(name == "vertebrae_L1" || name == "rib_left_1") << name;
    std::uint64_t count = 0;
    for (float v : skeleton.data) count += v == std::stof(value) ? 1 : 0;
    EXPECT_EQ(count, c.box.voxels()) << name;
    EXPECT_EQ(skeleton.data[grid_.linear(c.box.lo[0], c.box.lo[1], c.box.lo[2])], std::stof(value));
  }
  recorded.insert(kPrepJsonFile);
  EXPECT_EQ(files_in(out()), recorded);
}

TEST_F(PrepLabels, MultilabelNiftiGivesBoneVesselAndOrgans) {
  const std::string labels = write_multilabel("seg.nii.gz", kAbdomen);
  const PrepResult result = prep(labels);
  EXPECT_FALSE(result.from_cache);
  EXPECT_EQ(result.stats.bone_voxels, kVertebra.box.voxels() + kRib.box.voxels());
  expect_abdomen_outputs(labels, "totalsegmentator-multilabel");
  // The summary palp prep prints: bone, vessel, artery, then the organs, each with its source.
  ASSERT_EQ(result.structures.size(), 4u);
  EXPECT_EQ(result.structures[0].name, "bone");
  EXPECT_EQ(result.structures[0].source, "labels " + labels + " (vertebrae_L1, rib_left_1)");
  EXPECT_EQ(result.structures[1].name, "vessel");
  EXPECT_EQ(result.structures[2].name, "artery");
  EXPECT_EQ(result.structures[2].kind, "artery");
  EXPECT_EQ(result.structures[2].voxels, kAorta.box.voxels());
  EXPECT_EQ(result.structures[2].source, "labels " + labels + " (aorta)");
  EXPECT_EQ(result.structures[3].name, "liver");
  EXPECT_EQ(result.structures[3].voxels, 1000u);
  EXPECT_EQ(result.structures[3].source, "labels " + labels + " (liver)");
  EXPECT_EQ(read_json(out() / kPrepJsonFile)["parameters"]["labels"]["map"], "totalsegmentator");
}

TEST_F(PrepLabels, FolderGivesTheSame) {
  params_.labels_map.clear();  // a folder names its classes by file name
  const std::string folder = write_folder("seg", kAbdomen);
  prep(folder);
  expect_abdomen_outputs(folder, "totalsegmentator-folder");
}

TEST_F(PrepLabels, CachedUntilTheLabelsChangeAndAnEarlierRunsStructuresGo) {
  std::vector<Labelled> with_spleen = kAbdomen;
  with_spleen.push_back(kSpleen);
  const std::string labels = write_multilabel("seg.nii.gz", with_spleen);
  EXPECT_FALSE(prep(labels).from_cache);
  EXPECT_TRUE(fs::exists(out() / "spleen.nii.gz"));
  EXPECT_TRUE(fs::exists(out() / "d_spleen.nii.gz"));
  const PrepResult cached = prep(labels);
  EXPECT_TRUE(cached.from_cache);
  ASSERT_EQ(cached.structures.size(), 5u);
  EXPECT_EQ(cached.structures[2].name, "artery");
  EXPECT_EQ(cached.structures[4].name, "spleen");
  EXPECT_EQ(cached.structures[4].voxels, 64u);
  EXPECT_EQ(cached.vessel_voxels, kAorta.box.voxels() + kCava.box.voxels());
  // A structure file gone: not a valid cache.
  fs::remove(out() / "d_spleen.nii.gz");
  EXPECT_FALSE(prep(labels).from_cache);
  EXPECT_TRUE(prep(labels).from_cache);
  // The same name, other bytes (no spleen now): prepped again, and the spleen of the earlier run
  // does not stay behind to be taken for this one's.
  write_multilabel("seg.nii.gz", kAbdomen);
  EXPECT_FALSE(prep(labels).from_cache);
  expect_abdomen_outputs(labels, "totalsegmentator-multilabel");
  EXPECT_FALSE(fs::exists(out() / "spleen.nii.gz"));
  EXPECT_FALSE(fs::exists(out() / "d_spleen.nii.gz"));
  // Without the labels, the same directory is another result: bone from the HU (a sphere has
  // none), no vessel, no liver.
  params_.labels_map.clear();
  const PrepResult plain = prep("");
  EXPECT_FALSE(plain.from_cache);
  EXPECT_EQ(plain.stats.bone_voxels, 0u);
  ASSERT_EQ(plain.structures.size(), 1u);
  EXPECT_EQ(plain.structures[0].source, "auto");
  EXPECT_FALSE(fs::exists(out() / "liver.nii.gz"));
  EXPECT_FALSE(fs::exists(out() / "d_artery.nii.gz"));
  EXPECT_FALSE(fs::exists(out() / kVesselFile));
}

TEST_F(PrepLabels, WithoutBoneClassesTheBoneIsSegmentedAndTheOrgansStillWritten) {
  const std::string labels = write_multilabel("seg.nii.gz", {kLiver});
  const PrepResult result = prep(labels);
  EXPECT_EQ(result.stats.bone_voxels, 0u);  // the sphere's, from the HU
  const nlohmann::json json = read_json(out() / kPrepJsonFile);
  EXPECT_EQ(json["structures"]["bone"]["source"], "auto");
  EXPECT_FALSE(json["structures"].contains("vessel"));
  EXPECT_EQ(read_nifti_mask((out() / "liver.nii.gz").string()).data, mask_of(grid_, {kLiver}));
  EXPECT_FALSE(fs::exists(out() / kVesselFile));
  EXPECT_FALSE(fs::exists(out() / "artery.nii.gz")) << "no artery class, no artery";
  EXPECT_FALSE(json["structures"].contains("artery"));
}

TEST_F(PrepLabels, RefinedMapsForTheStructuresToo) {
  params_.map_spacing_mm = 1.0;  // 2 mm voxels: maps at 1 mm
  const std::string labels = write_multilabel("seg.nii.gz", kAbdomen);
  const PrepResult result = prep(labels);
  const DistanceMap d_liver = read_nifti_float((out() / "d_liver.nii.gz").string());
  EXPECT_EQ(d_liver.grid.dims, result.map_grid.dims);
  EXPECT_NE(d_liver.grid.dims, grid_.dims);
  EXPECT_EQ(read_nifti_mask((out() / "liver.nii.gz").string()).grid.dims, grid_.dims);
  EXPECT_EQ(read_nifti_float((out() / kVesselDistanceFile).string()).grid.dims,
            result.map_grid.dims);
  EXPECT_EQ(read_nifti_float((out() / "d_artery.nii.gz").string()).grid.dims, result.map_grid.dims);
}

TEST_F(PrepLabels, LabelsThatDoNotFitTheCtLeaveNothing) {
  // Another scan's labels, 1 m away: refused with the reader's message before anything is written.
  Grid elsewhere = grid_;
  elsewhere.world.origin[2] += 1000.0;
  const std::string labels = dir_.file("other.nii.gz");
  testing::write_label_nifti(labels, elsewhere, labels_of(elsewhere, kAbdomen));
  EXPECT_PALP_ERROR(prep(labels), InputError, "labels: " + labels + " does not overlap the CT");
  EXPECT_FALSE(fs::exists(out()));
  // In a directory that exists, nothing either.
  fs::create_directories(out());
  EXPECT_PALP_ERROR(prep(labels), InputError, "does not overlap the CT");
  EXPECT_TRUE(fs::is_empty(out()));
  // A missing label map: refused as the reader refuses it, before the CT is read.
  EXPECT_PALP_ERROR(prep(dir_.file("gone.nii.gz")), InputError,
                    "labels: " + dir_.file("gone.nii.gz") + ": no such file or directory");
  EXPECT_TRUE(fs::is_empty(out()));
  // A file without class names and no class map given.
  params_.labels_map.clear();
  EXPECT_PALP_ERROR(prep(write_multilabel("seg.nii.gz", kAbdomen)), InputError,
                    "give --labels-map totalsegmentator");
  EXPECT_TRUE(fs::is_empty(out()));
}

}  // namespace
}  // namespace palp
