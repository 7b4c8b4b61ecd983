// Tests common/scene/scene_maps.cpp: a prep directory's maps refined in memory on a coarse CT
// (the palp model's default): the grid, the bone map's function unchanged, the skin's distance
// nearer the exact one than the coarse nodes give, the same maps as prep's own refinement, and a
// note (maps as prepped) where a directory cannot be refined.
#include "scene/scene_maps.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>

#include "io/ct_io.hpp"
#include "model/field_sampler.hpp"
#include "prep/prep.hpp"
#include "scene/scene.hpp"
#include "support/io_test_util.hpp"
#include "support/partial_volume.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using palp::testing::TempDir;

constexpr double kVoxel = 3.0, kRadius = 30.0, kSkinHu = -500.0;
const Vec3d kCentre{40.3, 41.1, 39.6};

// A 3 mm CT of a soft-tissue ball (0 HU, R 30 mm) around a bone ball (700 HU, R 10 mm) in air,
// in partial volume, written as a file.
std::string write_coarse_ct(const TempDir& dir) {
  Grid g;
  g.dims = {28, 28, 28};
  g.spacing = {kVoxel, kVoxel, kVoxel};
  const CtVolume ct =
      testing::partial_volume_balls(g, {{kCentre, kRadius, 0.0}, {kCentre, 10.0, 700.0}}, -1000.0);
  const std::string path = dir.file("ball3.nii.gz");
  write_nifti(path, ct);
  return path;
}

std::string prep_into(const std::string& ct, const std::string& out, const PrepParams& params) {
  run_prep(ct, out, params);
  return out;
}

// The maps of one directory prepped on the CT's grid, shared by the tests (prep once).
class SceneMapsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir("scene-maps");
    ct_ = write_coarse_ct(*dir_);
    prep_ = prep_into(ct_, dir_->file("prep"), PrepParams{});
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static TempDir* dir_;
  static std::string ct_, prep_;
};
TempDir* SceneMapsTest::dir_ = nullptr;
std::string SceneMapsTest::ct_, SceneMapsTest::prep_;

TEST_F(SceneMapsTest, NoSpacingGivesTheFilesBitForBit) {
  const SceneMaps maps = read_scene_maps(prep_, 0.0);
  EXPECT_EQ(maps.refinement, (Refinement{1, 1, 1}));
  EXPECT_TRUE(maps.note.empty());
  EXPECT_EQ(maps.surf.data,
            read_nifti_float((fs::path(prep_) / kSurfaceDistanceFile).string()).data);
  EXPECT_EQ(maps.bone.data, read_nifti_float((fs::path(prep_) / kBoneDistanceFile).string()).data);
  // A grid already as fine as asked is not refined either, and says nothing.
  const SceneMaps fine_enough = read_scene_maps(prep_, 3.0);
  EXPECT_EQ(fine_enough.refinement, (Refinement{1, 1, 1}));
  EXPECT_TRUE(fine_enough.note.empty());
  EXPECT_EQ(fine_enough.surf.data, maps.surf.data);
}

TEST_F(SceneMapsTest, RefinedGridKeepsTheBoneMapsFunction) {
  const SceneMaps coarse = read_scene_maps(prep_, 0.0);
  const SceneMaps fine = read_scene_maps(prep_, kPalpMapSpacingMm);
  EXPECT_TRUE(fine.note.empty()) << fine.note;
  ASSERT_EQ(fine.refinement, (Refinement{2, 2, 2}));
  EXPECT_EQ(fine.surf.grid.dims, (Index3{55, 55, 55}));
  EXPECT_EQ(fine.surf.grid.spacing, (Vec3{1.5, 1.5, 1.5}));
  EXPECT_EQ(fine.bone.grid.dims, fine.surf.grid.dims);
  EXPECT_EQ(refinement_between(coarse.surf.grid, fine.surf.grid), (Refinement{2, 2, 2}));
  EXPECT_GT(fine.projected.projected, 0u);
  // d_bone: the same values at the CT's nodes, the same trilinear function between them.
  const Grid& g = coarse.bone.grid;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i)
        ASSERT_EQ(fine.bone.at(2 * i, 2 * j, 2 * k), coarse.bone.at(i, j, k)) << i << " " << j;
  const FieldSampler a(coarse.bone), b(fine.bone);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(1.0, 79.0);
  for (int n = 0; n < 2000; ++n) {
    const Vec3d x{u(rng), u(rng), u(rng)};
    ASSERT_NEAR(b.sample_surf(x).value, a.sample_surf(x).value, 1e-5);
  }
}

TEST_F(SceneMapsTest, RefinedSkinIsNearerTheExactDistance) {
  const CtVolume ct = read_ct(ct_);
  const FieldSampler coarse(read_scene_maps(prep_, 0.0).surf);
  const FieldSampler fine(read_scene_maps(prep_, kPalpMapSpacingMm).surf);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0), depth(1.5, 6.0);
  double sum2[2] = {0, 0};
  int count = 0;
  while (count < 2000) {
    Vec3d dir{u(rng), u(rng), u(rng)};
    if (!(norm(dir) > 0.1 && norm(dir) <= 1.0)) continue;
    dir = dir * (1.0 / norm(dir));
    const Vec3d x = kCentre + (kRadius - depth(rng)) * dir;
    const Vec3d on = kCentre + kRadius * dir;
    const double q[3] = {x.x, x.y, x.z};
    double start[3] = {on.x, on.y, on.z};
    const double exact = distance_to_iso_surface(ct, kSkinHu, q, start);
    ASSERT_GE(exact, 0.0);
    const double e0 = coarse.sample_surf(x).value - exact, e1 = fine.sample_surf(x).value - exact;
    sum2[0] += e0 * e0;
    sum2[1] += e1 * e1;
    ++count;
  }
  const double rms[2] = {std::sqrt(sum2[0] / count), std::sqrt(sum2[1] / count)};
  std::printf(
      "d_surf 1.5-6 mm deep against the exact distance, RMS: 3 mm nodes %.4f mm, refined "
      "in memory to 1.5 mm %.4f mm\n",
      rms[0], rms[1]);
  EXPECT_GE(rms[0], 0.05);
  EXPECT_LE(rms[1], 0.5 * rms[0]);
}

TEST_F(SceneMapsTest, AsGoodAsPrepsOwnRefinement) {
  // prep --map-spacing 2 refines before writing; the scene refines the written maps. Both project
  // the skin band at the fine nodes with the same function, prep starting from the CT-grid map
  // before its projection, the scene from the projected one: where the descent is refused
  // (beyond the reach, outside the skin) each keeps its own upsampled value. Measured at every
  // fine node 0.5-8 mm deep against the exact distance (the descent from the ball's radial point).
  PrepParams refined;
  refined.map_spacing_mm = kPalpMapSpacingMm;
  const std::string prepped = prep_into(ct_, dir_->file("prep-refined"), refined);
  const SceneMaps by_prep = read_scene_maps(prepped, 0.0);
  const SceneMaps in_memory = read_scene_maps(prep_, kPalpMapSpacingMm);
  ASSERT_EQ(by_prep.surf.grid.dims, in_memory.surf.grid.dims);
  EXPECT_EQ(by_prep.bone.data, in_memory.bone.data);
  const CtVolume ct = read_ct(ct_);
  const Grid& g = in_memory.surf.grid;
  double sum2[2] = {0, 0};
  std::size_t count = 0, differ = 0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const Vec3d x{i * g.spacing[0], j * g.spacing[1], k * g.spacing[2]};
        const double r = norm(x - kCentre);
        if (!(r >= kRadius - 8.5 && r <= kRadius)) continue;
        const Vec3d on = kCentre + (kRadius / r) * (x - kCentre);
        const double q[3] = {x.x, x.y, x.z};
        double start[3] = {on.x, on.y, on.z};
        const double exact = distance_to_iso_surface(ct, kSkinHu, q, start);
        if (!(exact >= 0.5 && exact <= 8.0)) continue;
        const double e[2] = {by_prep.surf.at(i, j, k) - exact, in_memory.surf.at(i, j, k) - exact};
        sum2[0] += e[0] * e[0];
        sum2[1] += e[1] * e[1];
        differ += by_prep.surf.at(i, j, k) != in_memory.surf.at(i, j, k);
        ++count;
      }
  ASSERT_GT(count, 10000u);
  const double rms[2] = {std::sqrt(sum2[0] / count), std::sqrt(sum2[1] / count)};
  std::printf(
      "d_surf at %zu fine nodes 0.5-8 mm deep against the exact distance, RMS: refined by "
      "prep %.4f mm, in memory %.4f mm (%zu nodes differ)\n",
      count, rms[0], rms[1], differ);
  EXPECT_LE(rms[1], rms[0] * 1.05);
  EXPECT_LE(rms[1], 0.05);
  // A directory prepped with --map-spacing is not refined again.
  const SceneMaps again = read_scene_maps(prepped, kPalpMapSpacingMm);
  EXPECT_EQ(again.refinement, (Refinement{1, 1, 1}));
  EXPECT_EQ(again.surf.data, by_prep.surf.data);
}

TEST_F(SceneMapsTest, WhatCannotBeRefinedIsSaid) {
  // No CT in the directory (a prep from before palp kept it): the maps as prepped, and why.
  const fs::path no_ct = dir_->path() / "no-ct";
  fs::create_directories(no_ct);
  for (const char* file : {kSurfaceDistanceFile, kBoneDistanceFile, kPrepJsonFile, kBodyFile})
    fs::copy_file(fs::path(prep_) / file, no_ct / file);
  const SceneMaps without_ct = read_scene_maps(no_ct.string(), kPalpMapSpacingMm);
  EXPECT_EQ(without_ct.refinement, (Refinement{1, 1, 1}));
  EXPECT_NE(without_ct.note.find("no ct.nii.gz"), std::string::npos) << without_ct.note;
  // Maps to the masks' faces: nothing to project onto.
  PrepParams mask;
  mask.surface.method = SurfaceMethod::mask;
  const std::string masks = prep_into(ct_, dir_->file("prep-mask"), mask);
  const SceneMaps of_masks = read_scene_maps(masks, kPalpMapSpacingMm);
  EXPECT_EQ(of_masks.refinement, (Refinement{1, 1, 1}));
  EXPECT_NE(of_masks.note.find("--surface mask"), std::string::npos) << of_masks.note;
  // A scene says it too, and keeps its spacing for reloading the maps (palpd's window).
  SceneOptions options;
  options.map_spacing_mm = kPalpMapSpacingMm;
  const Scene scene = load_scene(no_ct.string(), options);
  EXPECT_EQ(scene.grid.dims, (Index3{28, 28, 28}));
  EXPECT_EQ(scene.map_note, without_ct.note);
  const Scene refined = load_scene(prep_, options);
  EXPECT_EQ(refined.grid.dims, (Index3{55, 55, 55}));
  EXPECT_EQ(refined.map_refinement, (Refinement{2, 2, 2}));
  EXPECT_EQ(read_scene_maps(refined).surf.grid.dims, refined.grid.dims);
  // palpd's load keeps the CT and body mask (read once, handed to the refinement): the same maps,
  // and the CT on its own grid beside them.
  options.load_ct = true;
  const Scene with_ct = load_scene(prep_, options);
  ASSERT_TRUE(with_ct.ct && with_ct.body);
  EXPECT_EQ(with_ct.ct->grid.dims, (Index3{28, 28, 28}));
  EXPECT_EQ(with_ct.map_refinement, (Refinement{2, 2, 2}));
  const SceneMaps given =
      read_scene_maps(prep_, kPalpMapSpacingMm, 0, with_ct.ct.get(), with_ct.body.get());
  const SceneMaps read_here = read_scene_maps(prep_, kPalpMapSpacingMm);
  EXPECT_EQ(given.surf.data, read_here.surf.data);
  EXPECT_EQ(given.bone.data, read_here.bone.data);
  const Vec3d inside{40.0, 41.0, 40.0};
  EXPECT_EQ(with_ct.fields->sample_surf(inside).value, refined.fields->sample_surf(inside).value);
}

}  // namespace
}  // namespace palp
