// Tests for totalsegmentator.cpp through read_label_maps: the multi-label NIfTI of the `total`
// task (named by TotalSegmentator's header extension, or by --labels-map totalsegmentator) and the
// folder of one mask per class, with their refusals. Class ids are TotalSegmentator's own
// (totalsegmentator/map_to_binary.py, class_map["total"]), written here as literals.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "base/errors.hpp"
#include "prep/labels/label_classes.hpp"
#include "prep/labels/label_maps.hpp"
#include "support/io_test_util.hpp"
#include "support/label_files.hpp"

namespace palp {
namespace {

using testing::caret_label_table;
using testing::label_grid;
using testing::TempDir;
using testing::write_label_nifti;
using testing::write_label_nifti_with_extension;

const Grid kCt = label_grid({6, 5, 4});

std::vector<std::uint8_t> with(const Grid& g, std::vector<std::pair<Index3, std::uint8_t>> set) {
  std::vector<std::uint8_t> values(g.voxel_count(), 0);
  for (const auto& [at, value] : set) values[g.linear(at[0], at[1], at[2])] = value;
  return values;
}

Mask mask(const Grid& g, std::vector<Index3> on) {
  Mask m(g);
  for (const Index3& at : on) m.at(at[0], at[1], at[2]) = 1;
  return m;
}

// liver 5, aorta 52, inferior_vena_cava 63, vertebrae_L1 31, rib_left_1 92,
// lung_upper_lobe_left 10, lung_lower_lobe_left 11, gluteus_maximus_left 80.
const std::vector<std::uint8_t> kAbdomen = with(kCt, {{{0, 0, 0}, 5},
                                                      {{1, 0, 0}, 5},
                                                      {{2, 0, 0}, 52},
                                                      {{3, 0, 0}, 63},
                                                      {{0, 1, 0}, 31},
                                                      {{1, 1, 0}, 92},
                                                      {{0, 2, 0}, 10},
                                                      {{1, 2, 0}, 11},
                                                      {{5, 4, 3}, 80}});

const std::vector<std::pair<int, std::string>> kTable = {
    {5, "liver"},  {10, "lung_upper_lobe_left"}, {11, "lung_lower_lobe_left"}, {31, "vertebrae_L1"},
    {52, "aorta"}, {63, "inferior_vena_cava"},   {80, "gluteus_maximus_left"}, {92, "rib_left_1"}};

void expect_abdomen(const LabelMaps& maps) {
  EXPECT_EQ(maps.bone.data, mask(kCt, {{0, 1, 0}, {1, 1, 0}}).data);
  EXPECT_EQ(maps.artery.data, mask(kCt, {{2, 0, 0}}).data);
  EXPECT_EQ(maps.vein.data, mask(kCt, {{3, 0, 0}}).data);
  EXPECT_EQ(maps.vessel.data, mask(kCt, {{2, 0, 0}, {3, 0, 0}}).data);
  ASSERT_EQ(maps.organs.size(), 3u);
  EXPECT_EQ(maps.organs[0].name, "gluteus_maximus_left");
  EXPECT_EQ(maps.organs[0].kind, "muscle");
  EXPECT_EQ(maps.organs[1].name, "liver");
  EXPECT_EQ(maps.organs[1].kind, "organ");
  // The liver's box: CT voxels (0..1, 0, 0), placed where they are (1.5 mm voxels from -4, 7, 100).
  EXPECT_EQ(maps.organs[1].offset, (Index3{0, 0, 0}));
  EXPECT_EQ(maps.organs[1].mask.grid.dims, (Index3{2, 1, 1}));
  EXPECT_EQ(maps.organs[0].offset, (Index3{5, 4, 3}));
  EXPECT_EQ(maps.organs[0].mask.grid.world.origin, (Vec3{-4 + 7.5, 7 + 6, 100 + 4.5}));
  EXPECT_EQ(maps.organs[0].mask.data, std::vector<std::uint8_t>{1});
  EXPECT_EQ(on_ct_grid(maps.organs[1], kCt).data, mask(kCt, {{0, 0, 0}, {1, 0, 0}}).data);
  EXPECT_EQ(maps.organs[2].name, "lung_left");
  EXPECT_EQ(on_ct_grid(maps.organs[2], kCt).data, mask(kCt, {{0, 2, 0}, {1, 2, 0}}).data);
  EXPECT_EQ(maps.organs[2].source["classes"],
            (nlohmann::json{"lung_upper_lobe_left", "lung_lower_lobe_left"}));
  EXPECT_EQ(maps.source["structures"]["bone"]["classes"],
            (nlohmann::json{"vertebrae_L1", "rib_left_1"}));
  EXPECT_EQ(maps.source["structures"]["artery"]["voxels"], 1);
}

TEST(TotalSegmentatorMultilabel, NamedByItsHeaderExtension) {
  TempDir dir;
  write_label_nifti_with_extension(dir.file("seg.nii.gz"), kCt, kAbdomen,
                                   caret_label_table(kTable));
  const LabelMaps maps = read_label_maps(dir.file("seg.nii.gz"), kCt);
  expect_abdomen(maps);
  EXPECT_EQ(maps.source["format"], "totalsegmentator-multilabel");
  EXPECT_EQ(maps.source["resampled"], false);
  EXPECT_EQ(maps.organs[1].source["file"], dir.file("seg.nii.gz"));
  EXPECT_TRUE(maps.notes.empty());
}

TEST(TotalSegmentatorMultilabel, WithoutExtensionOnlyWithTheMapGiven) {
  TempDir dir;
  write_label_nifti(dir.file("seg.nii.gz"), kCt, kAbdomen);
  EXPECT_PALP_ERROR(read_label_maps(dir.file("seg.nii.gz"), kCt), InputError,
                    "seg.nii.gz: names no classes (no TotalSegmentator label table in its header); "
                    "if it is TotalSegmentator's total task (v2), give --labels-map "
                    "totalsegmentator");
  expect_abdomen(read_label_maps(dir.file("seg.nii.gz"), kCt, {kTotalSegmentatorMap}));
  EXPECT_PALP_ERROR(read_label_maps(dir.file("seg.nii.gz"), kCt, {"totalsegmentator-v1"}),
                    UsageError, "--labels-map: unknown class map \"totalsegmentator-v1\"");
}

TEST(TotalSegmentatorMultilabel, OwnNumberingIsReadByName) {
  TempDir dir;
  // An older TotalSegmentator (or another tool) numbering liver 1 and aorta 2.
  write_label_nifti_with_extension(dir.file("seg.nii"), kCt,
                                   with(kCt, {{{0, 0, 0}, 1}, {{1, 0, 0}, 2}}),
                                   caret_label_table({{1, "liver"}, {2, "aorta"}}));
  const LabelMaps maps = read_label_maps(dir.file("seg.nii"), kCt, {kTotalSegmentatorMap});
  ASSERT_EQ(maps.organs.size(), 1u);
  EXPECT_EQ(on_ct_grid(maps.organs[0], kCt).data, mask(kCt, {{0, 0, 0}}).data);
  EXPECT_EQ(maps.artery.data, mask(kCt, {{1, 0, 0}}).data);
  ASSERT_EQ(maps.notes.size(), 1u);
  EXPECT_NE(maps.notes[0].find("numbers the classes otherwise than TotalSegmentator v2.2"),
            std::string::npos);
}

TEST(TotalSegmentatorMultilabel, UnknownClassMapsAreRefusedByName) {
  TempDir dir;
  write_label_nifti_with_extension(dir.file("v1.nii.gz"), kCt, with(kCt, {{{0, 0, 0}, 44}}),
                                   caret_label_table({{5, "liver"}, {44, "heart_myocardium"}}));
  EXPECT_PALP_ERROR(read_label_maps(dir.file("v1.nii.gz"), kCt), InputError,
                    "v1.nii.gz: class 44 \"heart_myocardium\" is not a class of "
                    "TotalSegmentator's total task (v2)");
  write_label_nifti_with_extension(dir.file("more.nii.gz"), kCt,
                                   with(kCt, {{{0, 0, 0}, 5}, {{1, 0, 0}, 7}, {{2, 0, 0}, 7}}),
                                   caret_label_table({{5, "liver"}}));
  EXPECT_PALP_ERROR(read_label_maps(dir.file("more.nii.gz"), kCt), InputError,
                    "more.nii.gz: value 7 (2 voxels) has no name in its label table");
  write_label_nifti(dir.file("200.nii.gz"), kCt, with(kCt, {{{0, 0, 0}, 5}, {{1, 0, 0}, 200}}));
  EXPECT_PALP_ERROR(read_label_maps(dir.file("200.nii.gz"), kCt, {kTotalSegmentatorMap}),
                    InputError,
                    "200.nii.gz: values up to 200, but TotalSegmentator's total map "
                    "(--labels-map totalsegmentator) has 117 classes: not its total task");
}

TEST(TotalSegmentatorMultilabel, EmptyIsRefused) {
  TempDir dir;
  write_label_nifti_with_extension(dir.file("seg.nii.gz"), kCt, with(kCt, {}),
                                   caret_label_table(kTable));
  EXPECT_PALP_ERROR(read_label_maps(dir.file("seg.nii.gz"), kCt), InputError,
                    "labels: " + dir.file("seg.nii.gz") + " is empty (no voxel labelled)");
}

// TotalSegmentator's --fast model works at 3 mm: a 3 mm map on a 1.5 mm CT. Label voxel (a, b, c)
// at origin + 3 * (a, b, c) covers CT voxels 2a - 1 .. 2a (CT index 2a + 0.5 ties to 2a + 1).
TEST(TotalSegmentatorMultilabel, OtherGridIsResampledWithANote) {
  TempDir dir;
  const Grid coarse = label_grid({3, 3, 2}, {3, 3, 3});
  write_label_nifti_with_extension(dir.file("fast.nii.gz"), coarse, with(coarse, {{{1, 0, 0}, 5}}),
                                   caret_label_table(kTable));
  const LabelMaps maps = read_label_maps(dir.file("fast.nii.gz"), kCt);
  ASSERT_EQ(maps.organs.size(), 1u);
  // CT x index i at 1.5 i mm is nearest to label a = i / 2 (ties up): a = 1 for i = 1, 2.
  // Along y, b = 0 for j = 0 only (j = 1 is at 0.5: ties to 1); along z likewise c = 0 for k = 0.
  EXPECT_EQ(on_ct_grid(maps.organs[0], kCt).data, mask(kCt, {{1, 0, 0}, {2, 0, 0}}).data);
  EXPECT_EQ(maps.organs[0].source["resampled"], true);
  ASSERT_EQ(maps.notes.size(), 1u);
  EXPECT_EQ(maps.notes[0], dir.file("fast.nii.gz") +
                               ": resampled nearest-neighbour from 3 x 3 x 3 mm (3 x 3 x 2 voxels) "
                               "onto the CT's 1.5 x 1.5 x 1.5 mm (6 x 5 x 4 voxels)");
}

// ---- the folder ----

void write_class(const TempDir& dir, const std::string& name, std::vector<Index3> on) {
  std::vector<std::uint8_t> values(kCt.voxel_count(), 0);
  for (const Index3& at : on) values[kCt.linear(at[0], at[1], at[2])] = 1;
  write_label_nifti(dir.file(name + ".nii.gz"), kCt, values);
}

TEST(TotalSegmentatorFolder, OneMaskPerClass) {
  TempDir dir;
  write_class(dir, "liver", {{0, 0, 0}, {1, 0, 0}});
  write_class(dir, "aorta", {{2, 0, 0}});
  write_class(dir, "inferior_vena_cava", {{3, 0, 0}});
  write_class(dir, "vertebrae_L1", {{0, 1, 0}});
  write_class(dir, "rib_left_1", {{1, 1, 0}});
  write_class(dir, "lung_upper_lobe_left", {{0, 2, 0}});
  write_class(dir, "lung_lower_lobe_left", {{1, 2, 0}});
  write_class(dir, "gluteus_maximus_left", {{5, 4, 3}});
  testing::write_text(dir.file("statistics.json"), "{}");
  const LabelMaps maps = read_label_maps(dir.path().string(), kCt);
  EXPECT_EQ(maps.source["format"], "totalsegmentator-folder");
  EXPECT_EQ(maps.bone.data, mask(kCt, {{0, 1, 0}, {1, 1, 0}}).data);
  EXPECT_EQ(maps.vessel.data, mask(kCt, {{2, 0, 0}, {3, 0, 0}}).data);
  ASSERT_EQ(maps.organs.size(), 3u);
  EXPECT_EQ(maps.organs[2].name, "lung_left");
  EXPECT_EQ(on_ct_grid(maps.organs[2], kCt).data, mask(kCt, {{0, 2, 0}, {1, 2, 0}}).data);
  EXPECT_EQ(maps.notes,
            std::vector<std::string>{"ignored what is not a <class>.nii.gz: statistics.json"});
}

TEST(TotalSegmentatorFolder, WholeTaskSkipsItsEmptyClasses) {
  TempDir dir;
  const Grid small = label_grid({2, 2, 2});
  // Every class of the task, as TotalSegmentator writes them: those not in the scan empty.
  for (const labels::TotalClass& cls : labels::total_classes()) {
    std::vector<std::uint8_t> values(8, 0);
    values[0] = std::string(cls.name) == "liver";
    values[1] = std::string(cls.name) == "aorta";
    write_label_nifti(dir.file(std::string(cls.name) + ".nii.gz"), small, values);
  }
  const LabelMaps maps = read_label_maps(dir.path().string(), small);
  ASSERT_EQ(maps.organs.size(), 1u);
  EXPECT_EQ(maps.organs[0].name, "liver");
  EXPECT_EQ(maps.artery.data, (std::vector<std::uint8_t>{0, 1, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(maps.notes, std::vector<std::string>{"115 of the 117 class files are empty (the "
                                                 "classes are not in the scan)"});
  // A subset (--roi_subset): the user asked for each class, so an empty one is refused.
  std::filesystem::remove(dir.file("brain.nii.gz"));
  EXPECT_PALP_ERROR(read_label_maps(dir.path().string(), small), InputError,
                    "labels: " + dir.file("adrenal_gland_left.nii.gz") +
                        " is empty (delete it to go on without adrenal_gland_left)");
}

TEST(TotalSegmentatorFolder, Refusals) {
  TempDir dir;
  write_class(dir, "liver", {{0, 0, 0}});
  write_class(dir, "heart_myocardium", {{1, 0, 0}});
  EXPECT_PALP_ERROR(read_label_maps(dir.path().string(), kCt), InputError,
                    "heart_myocardium.nii.gz: \"heart_myocardium\" is not a class of "
                    "TotalSegmentator's total task (v2); move the file out of the folder");
  std::filesystem::remove(dir.file("heart_myocardium.nii.gz"));
  write_label_nifti(dir.file("aorta.nii.gz"), kCt, with(kCt, {{{0, 0, 0}, 2}}));
  EXPECT_PALP_ERROR(read_label_maps(dir.path().string(), kCt), InputError,
                    "aorta.nii.gz: holds the value 2: not a 0/1 mask");
  std::filesystem::remove(dir.file("aorta.nii.gz"));
  // TotalSegmentator's classes never share a voxel; files that do are not its output.
  write_class(dir, "spleen", {{2, 2, 2}, {0, 0, 0}});
  EXPECT_PALP_ERROR(read_label_maps(dir.path().string(), kCt), InputError,
                    "spleen.nii.gz: spleen overlaps liver on 1 CT voxels, the first (0, 0, 0)");
  std::filesystem::remove(dir.file("spleen.nii.gz"));
  std::filesystem::remove(dir.file("liver.nii.gz"));
  testing::write_text(dir.file("notes.txt"), "");
  EXPECT_PALP_ERROR(read_label_maps(dir.path().string(), kCt), InputError,
                    "holds no <class>.nii.gz of TotalSegmentator's total task");
}

}  // namespace
}  // namespace palp
