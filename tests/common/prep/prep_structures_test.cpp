// run_prep on the torso phantom drawn with `structures` (common/prep/prep_structures.cpp,
// issue 39): the phantom is its own expert, so prep writes its artery truth as artery.nii.gz +
// d_artery.nii.gz and its liver truth as liver.nii.gz + d_liver.nii.gz through the writer a label
// map's organs go through: the masks are the truth voxel for voxel, the maps positive exactly on
// them, on d_surf's grid; prep.json records both with their source; the body, bone and vessels
// are still prep's own; the cache tells the option apart; a lab's label map, when given, is the
// expert instead. The torso at 2.5 x 2.5 x 4 mm keeps the default field of view (nothing scaled):
// the femoral arteries are inside.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "io/ct_io.hpp"
#include "io/nifti.hpp"
#include "io/phantom.hpp"
#include "prep/labels/label_maps.hpp"
#include "prep/maps/map_refine.hpp"
#include "prep/prep.hpp"
#include "support/io_test_util.hpp"
#include "support/label_files.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

constexpr const char* kGrid = "dims=192x128x48,spacing=2.5x2.5x4";
const std::string kInput = std::string("phantom:torso,structures,") + kGrid;

nlohmann::json read_json(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

std::uint64_t count(const Mask& m) {
  std::uint64_t n = 0;
  for (std::uint8_t v : m.data) n += v != 0;
  return n;
}

class PrepPhantomStructures : public ::testing::Test {
 protected:
  void SetUp() override {
    params_.distance.threads = 2;
    const PhantomSpec spec = parse_phantom_spec(kInput.substr(std::string("phantom:").size()));
    make_phantom(spec.name, spec.options, &truth_);
  }
  fs::path out() const { return dir_.path() / "out"; }
  PrepResult prep(const std::string& input) { return run_prep(input, out().string(), params_); }

  TempDir dir_;
  PrepParams params_;
  PhantomTruth truth_;
};

// The map is positive exactly on the mask's voxels (at the CT's voxel centres: every node when
// the maps lie on the CT's grid, every k-th along each axis when refined by k).
std::int64_t sign_mismatches(const DistanceMap& map, const Mask& mask, const Refinement& k) {
  const Grid& g = mask.grid;
  std::int64_t wrong = 0;
  for (std::int64_t z = 0; z < g.dims[2]; ++z)
    for (std::int64_t y = 0; y < g.dims[1]; ++y)
      for (std::int64_t x = 0; x < g.dims[0]; ++x) {
        const float d = map.data[map.grid.linear(x * k[0], y * k[1], z * k[2])];
        wrong += (d > 0.0f) != (mask.at(x, y, z) != 0);
      }
  return wrong;
}

TEST_F(PrepPhantomStructures, WritesTheTruthsArteryAndLiverAsStructures) {
  ASSERT_GT(count(truth_.artery), 1000u);
  const PrepResult result = prep(kInput);
  const Mask artery = read_nifti_mask((out() / "artery.nii.gz").string());
  const Mask liver = read_nifti_mask((out() / "liver.nii.gz").string());
  EXPECT_EQ(artery.grid.dims, truth_.artery.grid.dims);
  EXPECT_TRUE(artery.data == truth_.artery.data);
  EXPECT_TRUE(liver.data == truth_.liver.data);
  const DistanceMap d_artery = read_nifti_float((out() / "d_artery.nii.gz").string());
  const DistanceMap d_liver = read_nifti_float((out() / "d_liver.nii.gz").string());
  const DistanceMap d_surf = read_nifti_float((out() / kSurfaceDistanceFile).string());
  EXPECT_EQ(d_artery.grid.dims, d_surf.grid.dims);
  EXPECT_EQ(d_liver.grid.dims, d_surf.grid.dims);
  EXPECT_EQ(sign_mismatches(d_artery, truth_.artery, {1, 1, 1}), 0);
  EXPECT_EQ(sign_mismatches(d_liver, truth_.liver, {1, 1, 1}), 0);

  const nlohmann::json json = read_json(out() / kPrepJsonFile);
  const nlohmann::json& s = json["structures"];
  EXPECT_EQ(s["artery"]["kind"], "artery");
  EXPECT_EQ(s["artery"]["voxels"], count(truth_.artery));
  EXPECT_EQ(s["artery"]["files"], nlohmann::json({"artery.nii.gz", "d_artery.nii.gz"}));
  EXPECT_EQ(s["artery"]["source"]["format"], "phantom-truth");
  EXPECT_EQ(s["artery"]["source"]["phantom"], kInput);
  EXPECT_EQ(s["liver"]["kind"], "organ");
  EXPECT_EQ(s["liver"]["voxels"], count(truth_.liver));
  EXPECT_EQ(s["liver"]["source"]["truth"], "liver");
  for (const char* file : {"artery.nii.gz", "d_artery.nii.gz", "liver.nii.gz", "d_liver.nii.gz"})
    EXPECT_EQ(json["file_bytes"][file], fs::file_size(out() / file)) << file;
  // Body, bone and vessels are segmented from the HU as without the option.
  EXPECT_EQ(s["bone"]["source"], "auto");
  EXPECT_EQ(s["vessel"]["source"], "auto");
  // The summary palp prep prints.
  ASSERT_EQ(result.structures.size(), 4u);
  EXPECT_EQ(result.structures[2].name, "artery");
  EXPECT_EQ(result.structures[2].source, "phantom truth " + kInput);
  EXPECT_EQ(result.structures[3].name, "liver");
  EXPECT_EQ(result.structures[3].voxels, count(truth_.liver));
}

TEST_F(PrepPhantomStructures, RefinedMapsLieOnDSurfsGrid) {
  params_.map_spacing_mm = 2.5;  // 2.5 x 2.5 x 4 mm voxels: the slices halved
  const PrepResult result = prep(kInput);
  const DistanceMap d_artery = read_nifti_float((out() / "d_artery.nii.gz").string());
  EXPECT_EQ(d_artery.grid.dims, result.map_grid.dims);
  EXPECT_NE(d_artery.grid.dims, truth_.artery.grid.dims);
  const Index3& fine = result.map_grid.dims;
  const Index3& coarse = truth_.artery.grid.dims;
  Refinement k{};
  for (int a = 0; a < 3; ++a) k[a] = static_cast<int>((fine[a] - 1) / (coarse[a] - 1));
  EXPECT_EQ(k, (Refinement{1, 1, 2}));
  EXPECT_EQ(sign_mismatches(d_artery, truth_.artery, k), 0);
}

TEST_F(PrepPhantomStructures, WithoutTheOptionNoStructureAndTheCacheTellsThemApart) {
  EXPECT_FALSE(prep(kInput).from_cache);
  EXPECT_TRUE(prep(kInput).from_cache);
  const std::string plain = std::string("phantom:torso,") + kGrid;
  const PrepResult without = prep(plain);
  EXPECT_FALSE(without.from_cache);
  for (const char* file : {"artery.nii.gz", "d_artery.nii.gz", "liver.nii.gz", "d_liver.nii.gz"})
    EXPECT_FALSE(fs::exists(out() / file)) << file << " of the earlier run stays behind";
  EXPECT_FALSE(read_json(out() / kPrepJsonFile)["structures"].contains("artery"));
  EXPECT_FALSE(prep(kInput).from_cache);
  EXPECT_TRUE(fs::exists(out() / "d_artery.nii.gz"));
}

TEST_F(PrepPhantomStructures, ALabelMapGivenIsTheExpertInstead) {
  // A label map of the phantom holding one liver box: its liver, no artery from the truth.
  const Grid grid = read_ct(kInput).grid;
  std::vector<std::uint8_t> values(grid.voxel_count(), 0);
  for (std::int64_t k = 20; k < 24; ++k)
    for (std::int64_t j = 30; j < 34; ++j)
      for (std::int64_t i = 60; i < 64; ++i) values[grid.linear(i, j, k)] = 5;  // liver's id
  const std::string labels = (dir_.path() / "seg.nii.gz").string();
  testing::write_label_nifti(labels, grid, values);
  params_.labels_path = labels;
  params_.labels_map = kTotalSegmentatorMap;
  prep(kInput);
  const nlohmann::json s = read_json(out() / kPrepJsonFile)["structures"];
  EXPECT_FALSE(s.contains("artery"));
  EXPECT_EQ(s["liver"]["voxels"], 64);
  EXPECT_EQ(s["liver"]["source"]["file"], labels);
  EXPECT_FALSE(fs::exists(out() / "artery.nii.gz"));
}

}  // namespace
}  // namespace palp
