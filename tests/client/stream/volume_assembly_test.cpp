// Render-volume assembly (client/stream/volume_assembly.cpp) of what palpd composes
// (server/net/scene_messages.cpp): a volume cropped to the body lands where the whole grid's
// volume did, voxel for voxel, and a crop that leaves the grid is refused.
#include "stream/volume_assembly.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "base/errors.hpp"
#include "net/scene_messages.hpp"
#include "stream/protocol_checks.hpp"
#include "support/palpd_test_util.hpp"
#include "wire/volume_codec.hpp"

namespace palp::view::net {
namespace {

using palp::net::SceneDescription;
using palp::net::VolumePlan;
using palp::StructureLabels;

// The 32^3 ball scene (2 mm voxels) with HU that encode the voxel index and a body box
// i in [9, 21), j in [5, 27), k in [12, 30).
SceneDescription boxed_scene() {
  SceneDescription scene;
  scene.fields = palp::testing::ball_fields();
  scene.grid = scene.fields->grid();
  auto ct = std::make_shared<CtVolume>(scene.grid);
  auto body = std::make_shared<Mask>(scene.grid);
  for (std::int64_t k = 0; k < 32; ++k)
    for (std::int64_t j = 0; j < 32; ++j)
      for (std::int64_t i = 0; i < 32; ++i) {
        ct->at(i, j, k) = static_cast<std::int16_t>(i + 32 * j + 1024 * k - 16000);
        body->at(i, j, k) = i >= 9 && i < 21 && j >= 5 && j < 27 && k >= 12 && k < 30;
      }
  scene.ct = ct;
  scene.body = body;
  return scene;
}

std::shared_ptr<RenderVolume> assemble(const SceneDescription& scene, const VolumePlan& plan,
                                       std::uint32_t max_dim) {
  const SceneGrid grid{scene.grid.dims,
                       {scene.grid.spacing[0], scene.grid.spacing[1], scene.grid.spacing[2]}};
  VolumeAssembly assembly;
  std::uint32_t k = 0;
  for (std::uint32_t c = 0; c < plan.chunks; ++c) {
    v1::VolumeChunk chunk;
    k += palp::net::fill_volume_chunk(scene, plan, k, c, &chunk);
    VolumeAssembly::Added added = assembly.add(chunk, max_dim, &grid);
    if (c + 1 == plan.chunks) return added.volume;
  }
  return nullptr;
}

TEST(VolumeAssembly, BodyBoxIsTheMaskBoundsPlusTheMargin) {
  const SceneDescription scene = boxed_scene();
  const palp::net::VoxelBox tight = palp::net::body_box(*scene.body, 0.0);
  EXPECT_EQ(tight.lo, (std::array<std::int64_t, 3>{9, 5, 12}));
  EXPECT_EQ(tight.hi, (std::array<std::int64_t, 3>{21, 27, 30}));
  // 5 mm at 2 mm voxels: 3 voxels, clamped to the grid.
  const palp::net::VoxelBox grown = palp::net::body_box(*scene.body, 5.0);
  EXPECT_EQ(grown.lo, (std::array<std::int64_t, 3>{6, 2, 9}));
  EXPECT_EQ(grown.hi, (std::array<std::int64_t, 3>{24, 30, 32}));
  Mask empty(scene.grid);
  EXPECT_TRUE(palp::net::body_box(empty, 5.0).empty());
}

TEST(VolumeAssembly, ACroppedVolumeLandsWhereTheWholeOneDidVoxelForVoxel) {
  const SceneDescription scene = boxed_scene();
  const palp::net::VoxelBox box = palp::net::body_box(*scene.body, 5.0);
  for (std::uint32_t step : {1u, 2u, 3u}) {
    SCOPED_TRACE("step " + std::to_string(step));
    const VolumePlan whole = palp::net::plan_volume(scene, {step, 0, true, false, true}, 2048);
    const VolumePlan cropped =
        palp::net::plan_volume(scene, {step, 0, true, false, true, true}, 2048, &box);
    ASSERT_EQ(cropped.step, step);
    const auto w = assemble(scene, whole, 64);
    const auto c = assemble(scene, cropped, 64);
    ASSERT_TRUE(w && c);
    EXPECT_EQ(w->origin, (std::array<double, 3>{0, 0, 0}));
    // The box's corner aligned down to the step; the box is covered.
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(cropped.offset[a] % step, 0);
      EXPECT_LE(cropped.offset[a], box.lo[a]);
      EXPECT_GE(cropped.offset[a] + c->dims[a] * step, box.hi[a]);
      EXPECT_LT(c->dims[a], w->dims[a] + (step == 1 ? 0 : 1));
      EXPECT_DOUBLE_EQ(c->origin[a], static_cast<double>(cropped.offset[a]) * 2.0);
      EXPECT_DOUBLE_EQ(c->spacing[a], w->spacing[a]);
    }
    EXPECT_LT(c->hu.size(), w->hu.size());
    // Each cropped voxel, at origin + (i, j, k) * spacing, is the whole volume's voxel there.
    for (std::int64_t k = 0; k < c->dims[2]; ++k)
      for (std::int64_t j = 0; j < c->dims[1]; ++j)
        for (std::int64_t i = 0; i < c->dims[0]; ++i) {
          const std::int64_t ijk[3] = {i, j, k};
          std::int64_t g[3];
          for (int a = 0; a < 3; ++a) {
            const double mm = c->origin[a] + static_cast<double>(ijk[a]) * c->spacing[a];
            const double wi = mm / w->spacing[a];
            ASSERT_EQ(wi, std::round(wi));
            g[a] = static_cast<std::int64_t>(wi);
            ASSERT_LT(g[a], w->dims[a]);
          }
          const auto cv = static_cast<std::size_t>(i + c->dims[0] * (j + c->dims[1] * k));
          const auto wv = static_cast<std::size_t>(g[0] + w->dims[0] * (g[1] + w->dims[1] * g[2]));
          ASSERT_EQ(c->hu[cv], w->hu[wv]);
          ASSERT_EQ(c->body[cv], w->body[wv]);
          ASSERT_EQ(c->d_surf[cv], w->d_surf[wv]);
        }
    // Every body voxel of the whole volume is in the cropped one.
    std::size_t body_whole = 0, body_cropped = 0;
    for (std::uint8_t b : w->body) body_whole += b;
    for (std::uint8_t b : c->body) body_cropped += b;
    EXPECT_EQ(body_cropped, body_whole);
    EXPECT_GT(body_whole, 0u);
  }
}

// With max_dim, the step follows the box, not the grid: more detail for the same budget.
TEST(VolumeAssembly, TheCropsStepFollowsTheBoxWithinMaxDim) {
  const SceneDescription scene = boxed_scene();
  const palp::net::VoxelBox box = palp::net::body_box(*scene.body, 0.0);  // 12 x 22 x 18
  const VolumePlan whole = palp::net::plan_volume(scene, {0, 22, true, false, true}, 2048);
  const VolumePlan cropped =
      palp::net::plan_volume(scene, {0, 22, true, false, true, true}, 2048, &box);
  EXPECT_EQ(whole.step, 2u);
  EXPECT_EQ(cropped.step, 1u);
  for (int a = 0; a < 3; ++a) EXPECT_LE(cropped.dims[a], 22);
  ASSERT_TRUE(assemble(scene, cropped, 22));
  // The crop needs the CT: a maps-only request is never cropped.
  const VolumePlan maps =
      palp::net::plan_volume(scene, {2, 0, false, false, true, true}, 2048, &box);
  EXPECT_EQ(maps.offset, (std::array<std::int64_t, 3>{}));
  EXPECT_EQ(maps.dims, whole.dims);
}

TEST(VolumeAssembly, ACropLeavingTheGridIsRefused) {
  const SceneDescription scene = boxed_scene();
  const palp::net::VoxelBox box = palp::net::body_box(*scene.body, 0.0);
  const VolumePlan plan =
      palp::net::plan_volume(scene, {1, 0, true, false, false, true}, 1 << 20, &box);
  v1::VolumeChunk chunk;
  palp::net::fill_volume_chunk(scene, plan, 0, 0, &chunk);
  const SceneGrid grid{scene.grid.dims, {2.0, 2.0, 2.0}};
  chunk.set_offset(0, 25);  // 25 + 12 voxels > 32
  VolumeAssembly assembly;
  EXPECT_THROW(assembly.add(chunk, 64, &grid), ProtocolViolation);
  chunk.set_offset(0, -1);
  EXPECT_THROW(assembly.add(chunk, 64, &grid), ProtocolViolation);
  chunk.clear_offset();
  chunk.add_offset(9);
  EXPECT_THROW(assembly.add(chunk, 64, &grid), ProtocolViolation);  // 1 offset, not 3
}

// ------------------------------------------------------------------ structure labels

// The boxed scene with two structures on its grid: a "vessel" slab (i in [4, 8)) and an "artery"
// ball of radius 3 voxels about voxel (16, 16, 16) over it.
SceneDescription labelled_scene() {
  SceneDescription scene = boxed_scene();
  auto labels = std::make_shared<StructureLabels>();
  labels->labels = Mask(scene.grid);
  for (std::int64_t k = 0; k < 32; ++k)
    for (std::int64_t j = 0; j < 32; ++j)
      for (std::int64_t i = 0; i < 32; ++i) {
        const std::int64_t r2 = (i - 16) * (i - 16) + (j - 16) * (j - 16) + (k - 16) * (k - 16);
        labels->labels.at(i, j, k) = r2 <= 9 ? 2 : (i >= 4 && i < 8) ? 1 : 0;
      }
  labels->structures = {{1, "vessel", "vessel"}, {2, "artery", "artery"}};
  scene.structures = labels;
  return scene;
}

// The labels go out with the volume when asked for, voxel for voxel the scene's at every step,
// raw or deflated, whole or cropped; not asked for (an older client), none come.
TEST(VolumeAssembly, StructureLabelsRoundTrip) {
  const SceneDescription scene = labelled_scene();
  const palp::net::VoxelBox box = palp::net::body_box(*scene.body, 5.0);
  const SceneGrid grid{scene.grid.dims, {2.0, 2.0, 2.0}, 2};
  for (const bool deflate : {false, true})
    for (const bool crop : {false, true})
      for (const std::uint32_t step : {1u, 2u}) {
        SCOPED_TRACE(std::to_string(step) + (deflate ? " deflated" : " raw") +
                     (crop ? " cropped" : ""));
        const VolumePlan plan = palp::net::plan_volume(
            scene, {step, 0, true, false, deflate, crop, true}, 4096, &box);
        ASSERT_TRUE(plan.labels);
        VolumeAssembly assembly;
        std::shared_ptr<RenderVolume> v;
        std::uint32_t k = 0;
        for (std::uint32_t c = 0; c < plan.chunks; ++c) {
          v1::VolumeChunk chunk;
          k += palp::net::fill_volume_chunk(scene, plan, k, c, &chunk);
          v = assembly.add(chunk, 64, &grid).volume;
        }
        ASSERT_TRUE(v);
        ASSERT_EQ(v->labels.size(), v->d_surf.size());
        std::size_t artery = 0;
        for (std::int64_t kk = 0; kk < v->dims[2]; ++kk)
          for (std::int64_t j = 0; j < v->dims[1]; ++j)
            for (std::int64_t i = 0; i < v->dims[0]; ++i) {
              const std::uint8_t got =
                  v->labels[static_cast<std::size_t>(i + v->dims[0] * (j + v->dims[1] * kk))];
              ASSERT_EQ(got, scene.structures->labels.at(plan.offset[0] + i * step,
                                                         plan.offset[1] + j * step,
                                                         plan.offset[2] + kk * step));
              artery += got == 2;
            }
        EXPECT_GT(artery, 0u);
      }
  const VolumePlan unasked = palp::net::plan_volume(scene, {1, 0, true, false, true}, 4096);
  EXPECT_FALSE(unasked.labels);
  v1::VolumeChunk chunk;
  palp::net::fill_volume_chunk(scene, unasked, 0, 0, &chunk);
  EXPECT_TRUE(chunk.labels().empty());
}

// A label volume over its bound is refused before it is spent: a raw field a byte longer than
// its slices, a zlib stream that inflates past them, a label SceneInfo did not list, labels
// when SceneInfo listed no structures.
TEST(VolumeAssembly, AnOversizeOrUnlistedLabelVolumeIsRefused) {
  const SceneDescription scene = labelled_scene();
  const SceneGrid grid{scene.grid.dims, {2.0, 2.0, 2.0}, 2};
  const auto chunk0 = [&](bool deflate) {
    const VolumePlan plan =
        palp::net::plan_volume(scene, {1, 0, false, false, deflate, false, true}, 1 << 20);
    v1::VolumeChunk chunk;
    palp::net::fill_volume_chunk(scene, plan, 0, 0, &chunk);
    return chunk;
  };
  v1::VolumeChunk raw = chunk0(false);
  ASSERT_EQ(raw.labels().size(), 32u * 32u * raw.k_count());
  raw.mutable_labels()->push_back('\0');
  EXPECT_THROW(VolumeAssembly().add(raw, 64, &grid), ProtocolViolation);
  v1::VolumeChunk zipped = chunk0(true);
  std::string longer(32u * 32u * zipped.k_count() + 1, '\0');
  zipped.set_labels(palp::wire::deflate_bytes(longer));
  EXPECT_THROW(VolumeAssembly().add(zipped, 64, &grid), ProtocolViolation);
  v1::VolumeChunk unlisted = chunk0(false);
  (*unlisted.mutable_labels())[5] = 3;  // SceneInfo lists labels 1 and 2
  EXPECT_THROW(VolumeAssembly().add(unlisted, 64, &grid), ProtocolViolation);
  const SceneGrid none{scene.grid.dims, {2.0, 2.0, 2.0}, 0};
  EXPECT_THROW(VolumeAssembly().add(chunk0(false), 64, &none), ProtocolViolation);
  EXPECT_THROW(VolumeAssembly().add(chunk0(false), 64, nullptr), ProtocolViolation);
  EXPECT_NO_THROW(VolumeAssembly().add(chunk0(false), 64, &grid));
}

}  // namespace
}  // namespace palp::view::net
