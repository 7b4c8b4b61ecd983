// The preprocessing pipeline end to end on small phantoms: outputs on the input grid voxel for
// voxel with the input's world placement, prep.json contents, and the content cache.
#include "prep/prep.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "io/ct_io.hpp"
#include "io/gzip.hpp"
#include "io/nifti.hpp"
#include "io/phantom.hpp"
#include "prep/maps/distance_transform.hpp"
#include "prep/maps/iso_projection.hpp"
#include "prep/maps/map_refine.hpp"
#include "prep/maps/subvoxel_distance.hpp"
#include "prep/segment/segmentation.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;

class PrepTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("palp_prep_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

// A small sphere phantom written with a non-trivial world placement.
std::string write_small_ct(const fs::path& dir, CtVolume* ct_out = nullptr) {
  PhantomOptions options;
  options.dims = Index3{50, 48, 46};
  options.spacing = Vec3{2.0, 2.0, 2.5};
  CtVolume ct = make_phantom("sphere", options);
  ct.grid.world.origin = {-41.5, 12.25, 100.0};
  ct.grid.world.direction = {0, 1, 0, -1, 0, 0, 0, 0, 1};  // i along -y, j along +x (LPS)
  const std::string path = (dir / "ct.nii.gz").string();
  write_nifti(path, ct);
  if (ct_out) *ct_out = read_ct(path);
  return path;
}

TEST_F(PrepTest, WritesAllOutputsOnTheInputGridWithItsWorldPlacement) {
  CtVolume ct;
  const std::string input = write_small_ct(dir_, &ct);
  PrepParams params;
  params.distance.threads = 2;
  params.surface.method = SurfaceMethod::mask;
  params.map_spacing_mm = 0.0;  // the CT's own grid (its 2.5 mm slices would be refined)
  const PrepResult result = run_prep(input, (dir_ / "out").string(), params);
  EXPECT_FALSE(result.from_cache);
  EXPECT_EQ(result.grid.dims, ct.grid.dims);
  EXPECT_EQ(result.map_grid.dims, ct.grid.dims);

  const Mask body = read_nifti_mask((dir_ / "out" / kBodyFile).string());
  const Mask bone = read_nifti_mask((dir_ / "out" / kBoneFile).string());
  const DistanceMap d_surf = read_nifti_float((dir_ / "out" / kSurfaceDistanceFile).string());
  const DistanceMap d_bone = read_nifti_float((dir_ / "out" / kBoneDistanceFile).string());
  for (const Grid* g : {&body.grid, &bone.grid, &d_surf.grid, &d_bone.grid}) {
    EXPECT_EQ(g->dims, ct.grid.dims);
    EXPECT_EQ(g->spacing, ct.grid.spacing);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(g->world.origin[a], ct.grid.world.origin[a], 1e-4);
    for (int a = 0; a < 9; ++a)
      EXPECT_NEAR(g->world.direction[a], ct.grid.world.direction[a], 1e-6);
  }
  // The written maps are exactly the maps of the written masks, voxel for voxel.
  const DistanceMap expected_surf = signed_distance(body, params.distance);
  const DistanceMap expected_bone = signed_distance(bone, params.distance);
  EXPECT_EQ(d_surf.data, expected_surf.data);
  EXPECT_EQ(d_bone.data, expected_bone.data);
  // A sphere has a body and no bone: D_bone is clamped to -band everywhere.
  EXPECT_GT(result.stats.body_voxels, 0u);
  EXPECT_EQ(result.stats.bone_voxels, 0u);
  for (float v : d_bone.data) ASSERT_EQ(v, -60.0f);

  std::ifstream json_file(dir_ / "out" / kPrepJsonFile);
  const auto json = nlohmann::json::parse(json_file);
  EXPECT_EQ(json["grid"]["dimensions"], nlohmann::json({50, 48, 46}));
  EXPECT_EQ(json["grid"]["spacing_mm"], nlohmann::json({2.0, 2.0, 2.5}));
  EXPECT_EQ(json["voxels"]["body"].get<std::uint64_t>(), result.stats.body_voxels);
  EXPECT_EQ(json["parameters"]["bone_seed_hu"], params.segmentation.bone_seed_hu);
  for (const char* stage : {"read CT", "body mask", "bone mask", "d_surf", "write d_surf",
                            "wait d_surf", "d_bone", "write d_bone", "total"}) {
    ASSERT_TRUE(json["timings_s"].contains(stage)) << stage;
    EXPECT_GE(json["timings_s"][stage].get<double>(), 0.0);
  }
  // CPU seconds of the whole process, per stage the main thread ran and in total.
  EXPECT_GT(json["cpu_seconds"]["total"].get<double>(), 0.0);
  EXPECT_FALSE(json["cpu_seconds"].contains("d_surf"));  // d_surf's own thread: wall time only
  EXPECT_GT(json["peak_memory_bytes"].get<std::uint64_t>(), 0u);
  EXPECT_EQ(json["surface"], "mask");
  EXPECT_FALSE(json.contains("surface_iso_hu"));
}

TEST_F(PrepTest, SubvoxelIsTheDefaultAndWritesTheMapsOfTheIsoSurfacesInsideTheMasks) {
  CtVolume ct;
  const std::string input = write_small_ct(dir_, &ct);
  PrepParams params;
  EXPECT_EQ(params.surface.method, SurfaceMethod::subvoxel);
  params.surface.skin_hu = -400.0;
  params.map_spacing_mm = 0.0;  // the CT's own grid (MapsOfACoarseCtLieOnItsAlignedRefinement)
  run_prep(input, (dir_ / "out").string(), params);
  const Mask body = read_nifti_mask((dir_ / "out" / kBodyFile).string());
  const DistanceMap d_surf = read_nifti_float((dir_ / "out" / kSurfaceDistanceFile).string());
  DistanceMap expected;
  const double band = 2.0 * 2.5;  // twice the coarsest spacing
  subvoxel_signed_distance(surface_points(ct, body, -400.0), body, band, params.distance.band_mm,
                           expected);
  {  // skin_projection_mm = 0: the tangent discs' map as it was
    PrepParams off = params;
    off.surface.skin_projection_mm = 0.0;
    run_prep(input, (dir_ / "off").string(), off);
    EXPECT_EQ(read_nifti_float((dir_ / "off" / kSurfaceDistanceFile).string()).data, expected.data);
  }
  // then moved onto the trilinear HU's iso-surface within three coarsest spacings inside, one
  // outside (prep/maps/iso_projection.hpp)
  const IsoProjectionStats moved = project_onto_iso_surface(
      ct, body, -400.0, 3.0 * 2.5, 2.5, 0.25 * 2.5, params.distance.band_mm, expected);
  EXPECT_GT(moved.projected, 0u);
  EXPECT_EQ(d_surf.data, expected.data);
  // It is not the mask's map: the surface moved off the voxel faces.
  EXPECT_NE(d_surf.data, signed_distance(body, params.distance).data);

  std::ifstream json_file(dir_ / "out" / kPrepJsonFile);
  const auto json = nlohmann::json::parse(json_file);
  EXPECT_EQ(json["surface"], "subvoxel");
  // threads 0 (the default) ran on the default count, and prep.json says how many that was.
  EXPECT_EQ(params.distance.threads, 0u);
  EXPECT_EQ(json["threads"].get<unsigned>(), default_thread_count());
  EXPECT_EQ(json["surface_iso_hu"]["skin"], -400.0);
  // The bone level follows the scan's soft-tissue peak (prep/segment/hu_levels.hpp), recorded
  // beside it.
  const double offset = json["hu_levels"]["offset_hu"];
  EXPECT_EQ(json["surface_iso_hu"]["bone"], 200.0 + offset);
  EXPECT_EQ(json["hu_levels"]["bone_iso_hu"], 200.0 + offset);
  EXPECT_EQ(json["hu_levels"]["bone_grow_hu"], 150.0 + offset);
  EXPECT_EQ(json["subvoxel_band_mm_used"], band);
  EXPECT_EQ(json["skin_projection"]["reach_mm"], 3.0 * 2.5);
  EXPECT_EQ(json["skin_projection"]["nodes"][1], moved.projected);
  const SurfacePoints skin = surface_points(ct, body, -400.0);
  EXPECT_EQ(json["surface_points"]["skin"][0], skin.points.size());
  EXPECT_EQ(json["surface_points"]["skin"][1], skin.interpolated);
  EXPECT_GT(skin.interpolated, skin.points.size() * 9 / 10);  // the sphere's skin is all HU
  EXPECT_EQ(json["surface_points"]["bone"][0], 0u);           // and it has no bone
  // The method is part of the cache key.
  PrepParams mask_params = params;
  mask_params.surface.method = SurfaceMethod::mask;
  EXPECT_NE(prep_cache_key(input, params), prep_cache_key(input, mask_params));
  EXPECT_EQ(parse_surface_method("mask"), SurfaceMethod::mask);
  EXPECT_THROW(parse_surface_method("voxel"), UsageError);
}

// By default the maps lie on the CT's grid voxel for voxel (the spec's outputs). With a map
// spacing of 2 mm the small CT's 2.5 mm slices are exceeded: the maps lie on its grid refined
// by 2 along k, nodes aligned; the masks and the CT copy stay on the CT's grid.
TEST_F(PrepTest, MapsOfACoarseCtLieOnItsAlignedRefinement) {
  CtVolume ct;
  const std::string input = write_small_ct(dir_, &ct);
  PrepParams params;
  const PrepResult by_default = run_prep(input, (dir_ / "default").string(), params);
  EXPECT_EQ(by_default.map_grid.dims, ct.grid.dims);
  EXPECT_EQ(read_nifti_float((dir_ / "default" / kSurfaceDistanceFile).string()).grid.dims,
            ct.grid.dims);
  params.map_spacing_mm = kSuggestedMapSpacingMm;
  const PrepResult result = run_prep(input, (dir_ / "out").string(), params);
  const Grid fine = refined_grid(ct.grid, {1, 1, 2});
  EXPECT_EQ(result.grid.dims, ct.grid.dims);
  EXPECT_EQ(result.map_grid.dims, (Index3{50, 48, 91}));
  EXPECT_EQ(result.map_grid.spacing, (Vec3{2.0, 2.0, 1.25}));
  const DistanceMap d_surf = read_nifti_float((dir_ / "out" / kSurfaceDistanceFile).string());
  const DistanceMap d_bone = read_nifti_float((dir_ / "out" / kBoneDistanceFile).string());
  const Mask body = read_nifti_mask((dir_ / "out" / kBodyFile).string());
  EXPECT_EQ(body.grid.dims, ct.grid.dims);
  EXPECT_EQ(read_ct((dir_ / "out" / kCtFile).string()).grid.dims, ct.grid.dims);
  for (const DistanceMap* m : {&d_surf, &d_bone}) {
    EXPECT_EQ(m->grid.dims, fine.dims);
    EXPECT_EQ(m->grid.spacing, fine.spacing);
    EXPECT_EQ(refinement_between(body.grid, m->grid), (Refinement{1, 1, 2}));
  }
  // d_surf: the CT grid's sub-voxel map upsampled, then projected on the fine nodes.
  PrepParams coarse = params;
  coarse.map_spacing_mm = 0.0;
  coarse.surface.skin_projection_mm = 0.0;
  run_prep(input, (dir_ / "coarse").string(), coarse);
  const DistanceMap discs = read_nifti_float((dir_ / "coarse" / kSurfaceDistanceFile).string());
  DistanceMap expected = upsample_aligned(discs, {1, 1, 2});
  const IsoProjectionStats moved = project_onto_iso_surface(
      ct, body, -500.0, 3.0 * 2.5, 2.5, 0.25 * 2.5, params.distance.band_mm, expected);
  EXPECT_GT(moved.projected, 0u);
  EXPECT_EQ(d_surf.data, expected.data);
  EXPECT_EQ(
      d_bone.data,
      upsample_aligned(read_nifti_float((dir_ / "coarse" / kBoneDistanceFile).string()), {1, 1, 2})
          .data);

  std::ifstream json_file(dir_ / "out" / kPrepJsonFile);
  const auto json = nlohmann::json::parse(json_file);
  EXPECT_EQ(json["grid"]["dimensions"], nlohmann::json({50, 48, 46}));
  EXPECT_EQ(json["map_grid"]["dimensions"], nlohmann::json({50, 48, 91}));
  EXPECT_EQ(json["map_grid"]["spacing_mm"], nlohmann::json({2.0, 2.0, 1.25}));
  EXPECT_EQ(json["map_grid"]["origin_lps_mm"], json["grid"]["origin_lps_mm"]);
  EXPECT_EQ(json["map_refinement"], nlohmann::json({1, 1, 2}));
  EXPECT_EQ(json["parameters"]["map_spacing_mm"], kSuggestedMapSpacingMm);
  EXPECT_EQ(json["skin_projection"]["nodes"][1], moved.projected);
  // The map spacing is part of the cache key, and a cached result names its map grid.
  EXPECT_NE(prep_cache_key(input, params), prep_cache_key(input, coarse));
  PrepParams other = params;
  other.map_spacing_mm = 1.0;
  EXPECT_NE(prep_cache_key(input, params), prep_cache_key(input, other));
  const PrepResult cached = run_prep(input, (dir_ / "out").string(), params);
  EXPECT_TRUE(cached.from_cache);
  EXPECT_EQ(cached.map_grid.dims, result.map_grid.dims);
  EXPECT_EQ(cached.map_grid.spacing, result.map_grid.spacing);
}

TEST_F(PrepTest, SecondRunIsServedFromTheCacheUntilInputOrParametersChange) {
  const std::string input = write_small_ct(dir_);
  const std::string out = (dir_ / "out").string();
  PrepParams params;
  EXPECT_FALSE(run_prep(input, out, params).from_cache);
  const PrepResult second = run_prep(input, out, params);
  EXPECT_TRUE(second.from_cache);
  EXPECT_TRUE(second.stages.empty());

  PrepParams no_cache = params;
  no_cache.use_cache = false;
  EXPECT_FALSE(run_prep(input, out, no_cache).from_cache);

  PrepParams other_band = params;
  other_band.distance.band_mm = 30.0;
  EXPECT_FALSE(run_prep(input, out, other_band).from_cache);
  EXPECT_TRUE(run_prep(input, out, other_band).from_cache);

  // Same name, different content: the cache follows the bytes, not the file name.
  PhantomOptions options;
  options.dims = Index3{30, 30, 30};
  write_nifti(input, make_phantom("sphere", options));
  EXPECT_FALSE(run_prep(input, out, other_band).from_cache);

  // A damaged output invalidates the cache.
  fs::resize_file(fs::path(out) / kSurfaceDistanceFile, 10);
  EXPECT_FALSE(run_prep(input, out, other_band).from_cache);
}

TEST_F(PrepTest, CacheKeyFollowsTheVoxelsOfADetachedHeader) {
  const std::string header = (dir_ / "ct.mhd").string();
  std::ofstream(header) << "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\n"
                           "ElementSpacing = 1 1 1\nElementType = MET_SHORT\n"
                           "ElementDataFile = ct.raw\n";
  std::ofstream(dir_ / "ct.raw", std::ios::binary) << std::string(16, '\0');
  const std::string before = prep_cache_key(header, {});
  EXPECT_EQ(prep_cache_key(header, {}), before);
  std::ofstream(dir_ / "ct.raw", std::ios::binary) << std::string(15, '\0') << 'x';
  EXPECT_NE(prep_cache_key(header, {}), before);  // same header, other voxels
}

// The cache key reads the input before prep does: it must not wait on a FIFO, read /dev/zero
// for ever or follow a loop of symbolic links (each hung `palp prep` before).
TEST_F(PrepTest, CacheKeyReadsOnlyRegularFiles) {
  const std::string fifo = (dir_ / "fifo.nii").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    (void)prep_cache_key(fifo, {});
    ADD_FAILURE() << "a FIFO was hashed";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("fifo.nii: a FIFO, not a regular file"), std::string::npos)
        << e.what();
  }
  const std::string header = (dir_ / "zero.mhd").string();
  std::ofstream(header) << "ObjectType = Image\nNDims = 3\nDimSize = 64 64 64\n"
                           "ElementType = MET_SHORT\nElementDataFile = /dev/zero\n";
  try {
    (void)prep_cache_key(header, {});
    ADD_FAILURE() << "/dev/zero was hashed";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("data file /dev/zero: a character device"),
              std::string::npos)
        << e.what();
  }
  fs::create_symlink("loop.raw", dir_ / "loop.raw");
  std::ofstream(dir_ / "loop.mhd") << "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\n"
                                      "ElementType = MET_SHORT\nElementDataFile = loop.raw\n";
  try {
    (void)prep_cache_key((dir_ / "loop.mhd").string(), {});
    ADD_FAILURE() << "a symlink loop was hashed";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("loop.raw: a loop of symbolic links"), std::string::npos)
        << e.what();
  }
}

// Bytes this process has read so far (/proc/self/io's rchar: every read and pread, all threads).
std::uint64_t bytes_read_so_far() {
  std::ifstream io("/proc/self/io");
  std::string key;
  std::uint64_t value = 0;
  while (io >> key >> value)
    if (key == "rchar:") return value;
  return 0;
}

// The cache key hashes every byte of the input; with no prep.json in the directory (no cached
// result possible) it waits until the readers have accepted the input. A 1 GiB sparse file of
// zeros behind a DICOM preamble is refused after reading a few kilobytes, where hashing it first
// read all of it (8 s on the 2-core VM).
TEST_F(PrepTest, AnInputTheReadersRefuseIsNotReadWholeFirst) {
  fs::create_directories(dir_ / "series");
  const fs::path file = dir_ / "series" / "zeros.dcm";
  {
    std::ofstream out(file, std::ios::binary);
    const std::string preamble(128, '\0');
    out << preamble << "DICM";
  }
  fs::resize_file(file, std::uint64_t{1} << 30);
  const std::uint64_t before = bytes_read_so_far();
  ASSERT_GT(before, 0u) << "/proc/self/io unreadable";
  EXPECT_THROW(run_prep((dir_ / "series").string(), (dir_ / "out").string(), {}), InputError);
  EXPECT_LT(bytes_read_so_far() - before, std::uint64_t{64} << 20);
}

TEST_F(PrepTest, AcceptsPhantomInputs) {
  EXPECT_NE(prep_cache_key("phantom:cube", {}), prep_cache_key("phantom:sphere", {}));
  EXPECT_THROW(run_prep("phantom:nonexistent", (dir_ / "out").string(), {}), UsageError);
}

TEST_F(PrepTest, BadInputThrowsAndLeavesNoPrepJson) {
  const fs::path bad = dir_ / "broken.nii.gz";
  std::ofstream(bad) << "this is not gzip";
  EXPECT_THROW(run_prep(bad.string(), (dir_ / "out").string(), {}), InputError);
  EXPECT_FALSE(fs::exists(dir_ / "out" / kPrepJsonFile));
  EXPECT_THROW(run_prep((dir_ / "missing.nii").string(), (dir_ / "out").string(), {}), InputError);
}

TEST_F(PrepTest, RefusedInputLeavesNoOutputDirectory) {
  const fs::path out = dir_ / "new" / "out";
  EXPECT_THROW(run_prep((dir_ / "missing.nii").string(), out.string(), {}), InputError);
  EXPECT_FALSE(fs::exists(dir_ / "new"));
  EXPECT_THROW(run_prep("phantom:nonexistent", out.string(), {}), UsageError);
  EXPECT_FALSE(fs::exists(dir_ / "new"));
}

TEST_F(PrepTest, FailedWriteLeavesNoTemporaryFile) {
  // d_surf.nii.gz is a directory holding a file: the rename onto it fails after the partial
  // file was written.
  const fs::path out = dir_ / "out";
  fs::create_directories(out / kSurfaceDistanceFile);
  std::ofstream(out / kSurfaceDistanceFile / "keep") << "x";
  PrepParams params;
  params.distance.threads = 2;
  EXPECT_THROW(run_prep("phantom:cube", out.string(), params), Error);
  for (const auto& entry : fs::directory_iterator(out)) {
    EXPECT_EQ(entry.path().string().find(".partial"), std::string::npos) << entry.path();
  }
  EXPECT_TRUE(fs::exists(out / kSurfaceDistanceFile / "keep"));
}

// The outputs do not depend on the thread count (the maps' passes, the background writes and the
// parallel gzip members): a torso with bone, prepped with 1 and 3 threads by both surface
// methods, gives byte-identical files, and the maps equal the single-threaded computation.
// The decompressed bytes, not the .nii.gz files: ISA-L's igzip (libisal 2.30) picks its matches
// by the buffers' addresses now and then, so the same bytes compress to another, equally valid
// stream in about 1 % of processes (measured on one 352-byte member: 14 of 1200 processes with
// address space randomization, 0 of 300 without; docs/prep.md, "Determinism of the written
// files").
TEST_F(PrepTest, OutputsAreByteIdenticalForAnyThreadCount) {
  PhantomOptions options;
  options.dims = Index3{72, 60, 30};
  options.spacing = Vec3{2.5, 2.5, 3.0};
  const CtVolume torso = make_phantom("torso", options);
  const std::string input = (dir_ / "torso.nii.gz").string();
  write_nifti(input, torso);
  for (const SurfaceMethod method : {SurfaceMethod::subvoxel, SurfaceMethod::mask}) {
    std::map<unsigned, fs::path> outs;
    for (const unsigned threads : {1u, 3u}) {
      PrepParams params;
      params.distance.threads = threads;
      params.surface.method = method;
      outs[threads] = dir_ / ("out_" + std::to_string(threads));
      run_prep(input, outs[threads].string(), params);
    }
    for (const char* name :
         {kBodyFile, kBoneFile, kSurfaceDistanceFile, kBoneDistanceFile, kCtFile}) {
      const auto decompressed = [&](const fs::path& path) {
        std::ifstream in(path, std::ios::binary);
        const std::vector<std::uint8_t> file{std::istreambuf_iterator<char>(in), {}};
        return decompress(ByteSpan(file.data(), file.size()), Compression::gzip,
                          std::size_t{1} << 30, path.string());
      };
      const std::vector<std::uint8_t> bytes_a = decompressed(outs[1] / name);
      EXPECT_FALSE(bytes_a.empty()) << name;
      EXPECT_TRUE(bytes_a == decompressed(outs[3] / name))
          << name << " (" << surface_method_name(method) << ")";
    }
    const Mask bone = read_nifti_mask((outs[3] / kBoneFile).string());
    EXPECT_GT(std::count(bone.data.begin(), bone.data.end(), 1), 100);
    if (method == SurfaceMethod::mask) {
      DistanceParams one;
      one.threads = 1;
      // On the CT's own grid (the default map spacing), voxel for voxel.
      ASSERT_EQ(map_refinement(bone.grid, kDefaultMapSpacingMm), (Refinement{1, 1, 1}));
      EXPECT_EQ(read_nifti_float((outs[3] / kBoneDistanceFile).string()).data,
                signed_distance(bone, one).data);
    }
    fs::remove_all(outs[1]);
    fs::remove_all(outs[3]);
  }
}

// The share (percent) of `truth`'s voxels that `mask` holds.
double percent_inside(const Mask& truth, const Mask& mask) {
  std::int64_t in = 0, all = 0;
  for (std::size_t n = 0; n < truth.size(); ++n) {
    all += truth.data[n] != 0;
    in += truth.data[n] && mask.data[n];
  }
  return all > 0 ? 100.0 * static_cast<double>(in) / static_cast<double>(all) : 0.0;
}

// The torso's arterial phase (aorta and its branches at 400 HU, above the bone seed level): the
// issue's goal, at most 5 % of the contrast-filled vessels inside bone, holds with the lumens grown
// into their branches (vessel_segmentation.hpp) and not without (the branches the opening cut
// off and the strip where the aorta rests on the spine go to bone: 6.2 % when measured).
TEST_F(PrepTest, AnArterialTreeAt400HuIsNotBone) {
  PhantomOptions options;
  options.contrast = PhantomContrast::arterial;
  PhantomTruth truth;
  const std::string input = (dir_ / "arterial.nii.gz").string();
  write_nifti(input, make_phantom("torso", options, &truth));
  ASSERT_GT(percent_inside(truth.vessel, truth.vessel), 99.0);
  run_prep(input, (dir_ / "out").string(), {});
  const Mask bone = read_nifti_mask((dir_ / "out" / kBoneFile).string());
  EXPECT_LE(percent_inside(truth.vessel, bone), 5.0);
  PrepParams no_branches;
  no_branches.vessels.find_branches = false;
  run_prep(input, (dir_ / "no_branches").string(), no_branches);
  const Mask bone_without = read_nifti_mask((dir_ / "no_branches" / kBoneFile).string());
  EXPECT_GT(percent_inside(truth.vessel, bone_without), 5.0) << "the case is no test of the rule";
}

TEST_F(PrepTest, NotACtIsRefusedUnlessAllowed) {
  CtVolume ct;
  write_small_ct(dir_, &ct);
  for (std::int16_t& v : ct.data) v = static_cast<std::int16_t>(v + 1024);  // rescale dropped
  const std::string input = (dir_ / "no_rescale.nii.gz").string();
  write_nifti(input, ct);
  try {
    run_prep(input, (dir_ / "out").string(), {});
    ADD_FAILURE() << "prepped a CT without its rescale";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("without its rescale"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir_ / "out" / kPrepJsonFile));
  PrepParams params;
  params.not_hu_ok = true;
  const PrepResult r = run_prep(input, (dir_ / "out").string(), params);
  EXPECT_FALSE(r.hu_warning.empty());
  std::ifstream in(dir_ / "out" / kPrepJsonFile);
  const auto json = nlohmann::json::parse(in);
  EXPECT_TRUE(json.contains("not_hu_ok"));
}

TEST_F(PrepTest, ObliqueInputIsResampledAndSaysSo) {
  CtVolume ct;
  write_small_ct(dir_, &ct);
  const double t = 15.0 * 3.14159265358979323846 / 180.0;  // turned about superior
  ct.grid.world.direction = {std::cos(t), -std::sin(t), 0, std::sin(t), std::cos(t), 0, 0, 0, 1};
  const std::string input = (dir_ / "oblique.nii.gz").string();
  write_nifti(input, ct);
  const PrepResult r = run_prep(input, (dir_ / "out").string(), {});
  EXPECT_TRUE(r.reoriented);
  EXPECT_NEAR(r.obliquity_deg, 15.0, 1e-3);
  EXPECT_NE(r.grid.dims, ct.grid.dims);
  const Mask body = read_nifti_mask((dir_ / "out" / kBodyFile).string());
  EXPECT_EQ(body.grid.world.direction, (std::array<double, 9>{1, 0, 0, 0, 1, 0, 0, 0, 1}));
  std::ifstream in(dir_ / "out" / kPrepJsonFile);
  const auto json = nlohmann::json::parse(in);
  EXPECT_TRUE(json.at("patient").at("reoriented").get<bool>());
  EXPECT_EQ(json.at("patient").at("orientation").get<std::string>(), "LPS");
  // the scene's CT is the resampled one, not a copy of the input
  EXPECT_EQ(read_ct((dir_ / "out" / kCtFile).string()).grid.dims, r.grid.dims);
}

std::string file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A gzip'd NIfTI used as read is copied as it is (its voxels are not deflated again); any other
// input is written. Either way the scene's CT reads back as the CT prep segmented.
TEST_F(PrepTest, TheScenesCtIsACopyOfAGzippedNiftiInputAndWrittenOtherwise) {
  CtVolume ct;
  write_small_ct(dir_, &ct);
  // stored as float32 HU: prep reads it as int16, so a written copy would differ from it
  std::vector<float> hu(ct.data.begin(), ct.data.end());
  const std::string gzipped = (dir_ / "float.nii.gz").string();
  write_nifti_file(gzipped, ct.grid, ScalarType::f32,
                   ByteSpan(reinterpret_cast<const std::uint8_t*>(hu.data()), hu.size() * 4),
                   -1000.0, 1000.0);
  fs::permissions(gzipped, fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
  PrepParams params;
  params.surface.method = SurfaceMethod::mask;
  params.map_spacing_mm = 0.0;
  run_prep(gzipped, (dir_ / "from_gz").string(), params);
  const fs::path copied = dir_ / "from_gz" / kCtFile;
  EXPECT_EQ(file_bytes(copied), file_bytes(gzipped));
  // a new file, not the read-only input's permissions
  EXPECT_NE(fs::status(copied).permissions() & fs::perms::owner_write, fs::perms::none);
  const std::string plain = (dir_ / "plain.nii").string();
  write_nifti(plain, ct);
  ASSERT_FALSE(file_is_gzip(plain));
  run_prep(plain, (dir_ / "from_nii").string(), params);
  const fs::path written = dir_ / "from_nii" / kCtFile;
  EXPECT_TRUE(file_is_gzip(written.string()));
  for (const fs::path& scene_ct : {copied, written}) {
    const CtVolume back = read_ct(scene_ct.string());
    EXPECT_EQ(back.grid.dims, ct.grid.dims) << scene_ct;
    EXPECT_EQ(back.grid.world.origin, ct.grid.world.origin) << scene_ct;
    EXPECT_EQ(back.grid.world.direction, ct.grid.world.direction) << scene_ct;
    EXPECT_EQ(back.data, ct.data) << scene_ct;
  }
  // no temporary left beside them
  for (const fs::path& out : {dir_ / "from_gz", dir_ / "from_nii"})
    for (const auto& entry : fs::directory_iterator(out))
      EXPECT_EQ(entry.path().string().find(".partial"), std::string::npos) << entry.path();
}

}  // namespace
}  // namespace palp
