// Loading scenes: prep directories, CT inputs prepped once into the cache, the sampler options,
// and one-line errors for incomplete directories and mismatched grids.
#include "scene/scene.hpp"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <string>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "io/phantom.hpp"
#include "prep/maps/map_refine.hpp"
#include "support/io_test_util.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using palp::testing::TempDir;
using palp::testing::write_text;

// A small cube CT written as a file (fast to prep).
std::string write_small_cube(const TempDir& dir) {
  PhantomOptions options;
  options.dims = Index3{40, 40, 40};
  options.spacing = Vec3{2.0, 2.0, 2.0};
  const std::string path = dir.file("cube.nii.gz");
  write_nifti(path, make_phantom("cube", options));
  return path;
}

// Prep output of the small cube in <dir>/prep.
std::string prep_small_cube(const TempDir& dir) {
  const std::string out = dir.file("prep");
  run_prep(write_small_cube(dir), out, PrepParams{});
  return out;
}

TEST(Scene, LoadsAPrepDirectory) {
  TempDir dir;
  const std::string prep = prep_small_cube(dir);
  ASSERT_TRUE(is_prep_directory(prep));
  const Scene scene = load_scene(prep);
  EXPECT_EQ(scene.prep_dir, prep);
  EXPECT_FALSE(scene.prepped);
  EXPECT_EQ(scene.grid.dims, (Index3{40, 40, 40}));
  EXPECT_EQ(scene.grid.spacing, (Vec3{2.0, 2.0, 2.0}));
  ASSERT_TRUE(scene.fields);
  EXPECT_TRUE(scene.fields->has_bone());
  // The cube's centre is deep inside; a grid corner is outside.
  const Vec3 e = scene.grid.extent_mm();
  EXPECT_GT(scene.fields->sample_surf({e[0] / 2, e[1] / 2, e[2] / 2}).value, 10.0);
  EXPECT_LT(scene.fields->sample_surf({0.0, 0.0, 0.0}).value, 0.0);
}

// A CT coarser than an asked map spacing: the scene's grid is the maps' (refined, aligned), the CT
// and body mask load on their own grid beside it, and the scene frame is the CT's.
TEST(Scene, MapsOnARefinedGridLoadWithTheirCt) {
  TempDir dir;
  PhantomOptions options;
  options.dims = Index3{30, 30, 30};
  options.spacing = Vec3{3.0, 3.0, 3.0};
  const std::string ct_path = dir.file("cube3.nii.gz");
  write_nifti(ct_path, make_phantom("cube", options));
  const std::string prep = dir.file("prep");
  PrepParams refined;
  refined.map_spacing_mm = kSuggestedMapSpacingMm;  // 3 mm -> 1.5 mm nodes
  run_prep(ct_path, prep, refined);
  SceneOptions load;
  load.load_ct = true;
  const Scene scene = load_scene(prep, load);
  EXPECT_EQ(scene.grid.dims, (Index3{59, 59, 59}));
  EXPECT_EQ(scene.grid.spacing, (Vec3{1.5, 1.5, 1.5}));
  ASSERT_TRUE(scene.ct && scene.body);
  EXPECT_EQ(scene.ct->grid.dims, (Index3{30, 30, 30}));
  EXPECT_EQ(scene.body->grid.dims, (Index3{30, 30, 30}));
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(scene.grid.extent_mm()[a], 87.0, 1e-9);
  // The same maps on the CT's own grid sample the same function away from the skin band.
  PrepParams coarse;
  coarse.map_spacing_mm = 0.0;
  run_prep(ct_path, dir.file("coarse"), coarse);
  const Scene own = load_scene(dir.file("coarse"), load);
  EXPECT_EQ(own.grid.dims, (Index3{30, 30, 30}));
  for (const Vec3d x : {Vec3d{43.5, 43.5, 43.5}, Vec3d{10.2, 40.7, 61.3}, Vec3d{1.0, 2.0, 3.0}})
    EXPECT_NEAR(scene.fields->sample_bone(x).value, own.fields->sample_bone(x).value, 1e-5);
}

TEST(Scene, CtInputIsPreppedOnceIntoTheCache) {
  TempDir dir;
  const std::string ct = write_small_cube(dir);
  SceneOptions options;
  options.cache_dir = dir.file("cache");
  const Scene first = load_scene(ct, options);
  EXPECT_TRUE(first.prepped);
  EXPECT_EQ(first.prep_dir, scene_cache_path(ct, options.prep, options.cache_dir));
  EXPECT_TRUE(is_prep_directory(first.prep_dir));
  const Scene second = load_scene(ct, options);
  EXPECT_FALSE(second.prepped);
  EXPECT_EQ(second.prep_dir, first.prep_dir);
  EXPECT_EQ(second.grid, first.grid);
  // Other prep parameters are another cache entry.
  options.prep.distance.band_mm = 30.0;
  const Scene third = load_scene(ct, options);
  EXPECT_TRUE(third.prepped);
  EXPECT_NE(third.prep_dir, first.prep_dir);
}

TEST(Scene, PhantomScenes) {
  TempDir dir;
  SceneOptions options;
  options.cache_dir = dir.path().string();
  const Scene scene = load_scene("phantom:cube", options);
  EXPECT_EQ(scene.grid.dims, phantom_grid("cube").dims);
  EXPECT_TRUE(scene.prepped);
  EXPECT_FALSE(load_scene("phantom:cube", options).prepped);
}

TEST(Scene, SamplerConfigIsApplied) {
  TempDir dir;
  const std::string prep = prep_small_cube(dir);
  SceneOptions options;
  options.sampler = {GradientScheme::PrecomputedField, Storage::Int16};
  const Scene scene = load_scene(prep, options);
  EXPECT_EQ(scene.fields->config().gradient, GradientScheme::PrecomputedField);
  EXPECT_EQ(scene.fields->config().storage, Storage::Int16);
  EXPECT_GT(scene.fields->surf_quantum(), 0.0);
}

TEST(Scene, MissingMapsAreNamed) {
  TempDir dir;
  const std::string prep = prep_small_cube(dir);
  fs::remove(fs::path(prep) / kBoneDistanceFile);
  EXPECT_PALP_ERROR(load_scene(prep), InputError, "missing d_bone.nii.gz");
  fs::remove(fs::path(prep) / kSurfaceDistanceFile);
  EXPECT_PALP_ERROR(load_scene(prep), InputError, "missing d_surf.nii.gz");
}

TEST(Scene, MapsOnDifferentGridsAreRefused) {
  TempDir dir;
  const std::string prep = prep_small_cube(dir);
  Grid other;
  other.dims = {40, 40, 39};
  other.spacing = {2.0, 2.0, 2.0};
  write_nifti((fs::path(prep) / kBoneDistanceFile).string(), DistanceMap(other, -5.0f));
  EXPECT_PALP_ERROR(load_scene(prep), InputError, "different grids");
}

TEST(Scene, UnusableInputs) {
  TempDir dir;
  SceneOptions options;
  options.cache_dir = dir.file("cache");
  EXPECT_PALP_ERROR(load_scene("", options), UsageError, "empty scene");
  EXPECT_PALP_ERROR(load_scene(dir.file("missing.nii.gz"), options), InputError, "missing.nii.gz");
  EXPECT_PALP_ERROR(load_scene("phantom:nothing", options), UsageError, "nothing");
  write_text(dir.file("not_a_ct.nii.gz"), "hello");
  EXPECT_THROW(load_scene(dir.file("not_a_ct.nii.gz"), options), Error);
}

TEST(Scene, DefaultCacheDirectoryFollowsTheEnvironment) {
  const char* saved_palp = std::getenv("PALP_SCENE_CACHE");
  const char* saved_xdg = std::getenv("XDG_CACHE_HOME");
  const std::string palp_value = saved_palp ? saved_palp : "";
  const std::string xdg_value = saved_xdg ? saved_xdg : "";
  ::setenv("PALP_SCENE_CACHE", "/tmp/palp-explicit", 1);
  EXPECT_EQ(default_scene_cache_dir(), "/tmp/palp-explicit");
  ::unsetenv("PALP_SCENE_CACHE");
  ::setenv("XDG_CACHE_HOME", "/tmp/xdg", 1);
  EXPECT_EQ(default_scene_cache_dir(), "/tmp/xdg/palp/scenes");
  ::unsetenv("XDG_CACHE_HOME");
  EXPECT_NE(default_scene_cache_dir().find("palp"), std::string::npos);
  if (saved_palp) ::setenv("PALP_SCENE_CACHE", palp_value.c_str(), 1);
  if (saved_xdg) ::setenv("XDG_CACHE_HOME", xdg_value.c_str(), 1);
}

}  // namespace
}  // namespace palp
