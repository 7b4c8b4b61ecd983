// The structures of a prep directory as one label volume (common/scene/structure_labels.cpp):
// tiny prep directories written here (a ball "artery" inside a slab of "vessel", an organ recorded
// in prep.json), their labels in order, the artery over the vessels over the organ, masks on a
// coarser grid taken at the nearest node, and what is left out said, never thrown.
#include "scene/structure_labels.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "io/ct_io.hpp"
#include "prep/maps/map_refine.hpp"
#include "support/io_test_util.hpp"

namespace palp {
namespace {

Grid grid_of(std::int64_t n, double spacing) {
  Grid g;
  g.dims = {n, n, n};
  g.spacing = {spacing, spacing, spacing};
  return g;
}

// A mask on `grid` set where `inside(i, j, k)`.
template <class F>
Mask mask_of(const Grid& grid, F inside) {
  Mask m(grid);
  for (std::int64_t k = 0; k < grid.dims[2]; ++k)
    for (std::int64_t j = 0; j < grid.dims[1]; ++j)
      for (std::int64_t i = 0; i < grid.dims[0]; ++i) m.at(i, j, k) = inside(i, j, k) ? 1 : 0;
  return m;
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

bool in_ball(std::int64_t i, std::int64_t j, std::int64_t k, std::int64_t c, std::int64_t r) {
  return (i - c) * (i - c) + (j - c) * (j - c) + (k - c) * (k - c) <= r * r;
}

// vessel: the slab i in [8, 12); artery: a ball of radius 2 voxels about (10, 10, 10), inside the
// slab; liver (prep.json, kind organ): i >= 9, under both.
TEST(StructureLabels, ALabelEachInOrderTheArteryOnTop) {
  testing::TempDir dir("structure-labels");
  const Grid g = grid_of(20, 2.0);
  write_nifti(dir.file("vessel.nii.gz"),
              mask_of(g, [](auto i, auto, auto) { return i >= 8 && i < 12; }));
  write_nifti(dir.file("artery.nii.gz"),
              mask_of(g, [](auto i, auto j, auto k) { return in_ball(i, j, k, 10, 2); }));
  write_nifti(dir.file("liver.nii.gz"), mask_of(g, [](auto i, auto, auto) { return i >= 9; }));
  write_nifti(dir.file("psoas.nii.gz"), mask_of(g, [](auto, auto, auto) { return true; }));
  write_text(dir.file("prep.json"),
             R"({"structures": {"liver": {"kind": "organ", "files": ["liver.nii.gz"]},
                                "psoas": {"kind": "muscle", "files": ["psoas.nii.gz"]},
                                "vessel": {"kind": "vessel"}}})");
  const StructureLabels s = read_structure_labels(dir.path().string(), g);
  EXPECT_EQ(s.note, "");
  ASSERT_EQ(s.structures.size(), 3u);  // the muscle is not drawn
  EXPECT_EQ(s.structures[0].name, "vessel");
  EXPECT_EQ(s.structures[0].label, 1);
  EXPECT_EQ(s.structures[1].name, "artery");
  EXPECT_EQ(s.structures[1].kind, "artery");
  EXPECT_EQ(s.structures[1].label, 2);
  EXPECT_EQ(s.structures[2].name, "liver");
  EXPECT_EQ(s.structures[2].kind, "organ");
  EXPECT_EQ(s.structures[2].label, 3);
  EXPECT_EQ(s.labels.at(10, 10, 10), 2);  // the artery's centre: over the vessel and the liver
  EXPECT_EQ(s.labels.at(10, 10, 13), 1);  // the slab outside the ball: over the liver
  EXPECT_EQ(s.labels.at(8, 3, 3), 1);     // the slab where no liver is
  EXPECT_EQ(s.labels.at(15, 3, 3), 3);    // the liver alone
  EXPECT_EQ(s.labels.at(2, 3, 3), 0);     // nothing
  std::size_t artery = 0;
  for (std::uint8_t v : s.labels.data) artery += v == 2;
  EXPECT_EQ(artery, 33u);  // the voxels within 2 of a voxel centre: 1 + 6 + 12 + 8 + 6
}

// Masks on the CT's grid under maps refined twice: the maps' voxel takes the nearest node's label.
TEST(StructureLabels, MasksOnACoarserGridTakeTheNearestNode) {
  testing::TempDir dir("structure-labels-coarse");
  const Grid ct = grid_of(11, 4.0), maps = grid_of(21, 2.0);
  ASSERT_EQ(refinement_between(ct, maps), (Refinement{2, 2, 2}));
  write_nifti(dir.file("artery.nii.gz"), mask_of(ct, [](auto i, auto, auto) { return i == 3; }));
  const StructureLabels s = read_structure_labels(dir.path().string(), maps);
  ASSERT_EQ(s.structures.size(), 1u);
  EXPECT_EQ(s.structures[0].label, 1);
  EXPECT_EQ(s.labels.grid.dims, ct.dims);
  const Refinement r = refinement_between(s.labels.grid, maps);
  // Node 3 lies at 12 mm: the maps' voxels at 10 mm (a tie: the later node) and 12 mm take it,
  // the one at 8 mm (node 2) and at 14 mm (a tie: node 4) do not.
  EXPECT_EQ(label_at(s.labels, r, 4, 0, 0), 0);
  EXPECT_EQ(label_at(s.labels, r, 5, 0, 0), 1);
  EXPECT_EQ(label_at(s.labels, r, 6, 0, 0), 1);
  EXPECT_EQ(label_at(s.labels, r, 7, 0, 0), 0);
  EXPECT_EQ(label_at(s.labels, r, 99, 0, 0), 0);  // outside: none
}

// No structures: nothing; a mask on another grid or an unreadable one: left out and said; a
// prep.json naming a path: refused as a file name.
TEST(StructureLabels, WhatCannotBeUsedIsLeftOutAndSaid) {
  testing::TempDir dir("structure-labels-bad");
  const Grid g = grid_of(12, 2.0);
  EXPECT_TRUE(read_structure_labels(dir.path().string(), g).structures.empty());
  EXPECT_EQ(read_structure_labels(dir.path().string(), g).note, "");
  write_nifti(dir.file("vessel.nii.gz"), mask_of(grid_of(7, 3.0), [](auto, auto, auto) {
                return true;
              }));
  write_text(dir.file("artery.nii.gz"), "not a NIfTI file");
  write_text(dir.file("prep.json"),
             R"({"structures": {"kidney": {"kind": "organ", "files": ["../kidney.nii.gz"]}}})");
  const StructureLabels s = read_structure_labels(dir.path().string(), g);
  EXPECT_TRUE(s.structures.empty());
  EXPECT_NE(s.note.find("organ 'kidney': not a plain mask file name"), std::string::npos) << s.note;
  EXPECT_NE(s.note.find("vessel.nii.gz is not on the maps' grid"), std::string::npos) << s.note;
  EXPECT_NE(s.note.find("artery.nii.gz unreadable"), std::string::npos) << s.note;
}

}  // namespace
}  // namespace palp
