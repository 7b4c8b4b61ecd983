// The render volume palpd composes (server/net/scene_messages.cpp): the CT's HU and body mask at
// the step asked, deflated on request, and every chunk bounded whatever a client asks.
#include "net/scene_messages.hpp"

#include <gtest/gtest.h>

#include <cstring>

#include "prep/maps/map_refine.hpp"
#include "support/palpd_test_util.hpp"
#include "wire/volume_codec.hpp"

namespace palp::net {
namespace {

// The 32^3 ball scene with a CT whose HU encode the voxel index and a body mask of odd i.
SceneDescription ct_scene() {
  SceneDescription scene;
  scene.fields = testing::ball_fields();
  scene.grid = scene.fields->grid();
  auto ct = std::make_shared<CtVolume>(scene.grid);
  auto body = std::make_shared<Mask>(scene.grid);
  for (std::int64_t k = 0; k < 32; ++k)
    for (std::int64_t j = 0; j < 32; ++j)
      for (std::int64_t i = 0; i < 32; ++i) {
        ct->at(i, j, k) = static_cast<std::int16_t>(i + 32 * j + 1024 * k - 16000);
        body->at(i, j, k) = static_cast<std::uint8_t>(i % 2);
      }
  scene.ct = ct;
  scene.body = body;
  return scene;
}

TEST(SceneMessages, ShipsTheCtAtTheStepAskedDeflated) {
  const SceneDescription scene = ct_scene();
  const VolumePlan plan = plan_volume(scene, {2, 0, true, false, true}, 4096);
  ASSERT_EQ(plan.step, 2u);
  ASSERT_TRUE(plan.hu && plan.deflate && !plan.bone);
  EXPECT_EQ(plan.dims, (std::array<std::int64_t, 3>{16, 16, 16}));
  EXPECT_EQ(plan.voxel_bytes, 7u);  // d_surf 4 + hu 2 + body 1
  EXPECT_EQ(plan.slab, 4096u / (16 * 16 * 7));
  std::uint32_t k = 0;
  for (std::uint32_t c = 0; c < plan.chunks; ++c) {
    v1::VolumeChunk chunk;
    const std::uint32_t got = fill_volume_chunk(scene, plan, k, c, &chunk);
    ASSERT_TRUE(chunk.deflate());
    EXPECT_TRUE(chunk.d_bone().empty());
    const std::size_t n = 16u * 16u * got;
    std::string hu, body;
    ASSERT_TRUE(wire::inflate_exact(chunk.hu(), n * 2, hu));
    ASSERT_TRUE(wire::inflate_exact(chunk.body(), n, body));
    for (std::size_t v = 0; v < n; ++v) {
      const std::int64_t i = 2 * static_cast<std::int64_t>(v % 16);
      const std::int64_t j = 2 * static_cast<std::int64_t>((v / 16) % 16);
      const std::int64_t kk = 2 * (k + static_cast<std::int64_t>(v / 256));
      std::int16_t h;
      std::memcpy(&h, hu.data() + 2 * v, 2);
      ASSERT_EQ(h, i + 32 * j + 1024 * kk - 16000);
      ASSERT_EQ(body[v], 0);  // even i: outside the mask
    }
    k += got;
  }
  EXPECT_EQ(k, 16u);
}

// Maps on the CT's grid refined by 2 (prep/maps/map_refine.hpp): the HU and body go out from the
// CT's nearest node, and the body's crop box (in CT voxels) is scaled onto the maps' grid.
TEST(SceneMessages, MapsOnARefinedGridShipTheCtsNearestNode) {
  const SceneDescription coarse = ct_scene();
  SceneDescription scene = coarse;
  scene.grid = refined_grid(coarse.grid, {2, 2, 2});  // 63^3 nodes of half the spacing
  DistanceMap fine(scene.grid, 0.0f, "fine");
  scene.fields = std::make_shared<const FieldSampler>(fine);
  const VolumePlan plan = plan_volume(scene, {1, 0, true, false, false}, 1 << 20);
  ASSERT_TRUE(plan.hu);
  EXPECT_EQ(plan.dims, (std::array<std::int64_t, 3>{63, 63, 63}));
  v1::VolumeChunk chunk;
  const std::uint32_t got = fill_volume_chunk(scene, plan, 0, 0, &chunk);
  ASSERT_GT(got, 3u);
  const std::string& hu = chunk.hu();
  for (const auto [i, j, k] :
       {std::array<std::int64_t, 3>{0, 0, 0}, {4, 6, 2}, {5, 3, 1}, {62, 61, 3}}) {
    std::int16_t h;
    std::memcpy(&h, hu.data() + 2 * (i + 63 * (j + 63 * k)), 2);
    const std::int64_t ci = (i + 1) / 2, cj = (j + 1) / 2, ck = (k + 1) / 2;  // nearest node
    EXPECT_EQ(h, ci + 32 * cj + 1024 * ck - 16000) << i << " " << j << " " << k;
  }
  const VoxelBox crop{{2, 3, 4}, {10, 11, 12}};  // CT voxels
  const VolumePlan cropped = plan_volume(scene, {1, 0, true, false, false, true}, 1 << 20, &crop);
  EXPECT_EQ(cropped.offset, (std::array<std::int64_t, 3>{4, 6, 8}));
  EXPECT_EQ(cropped.dims, (std::array<std::int64_t, 3>{15, 15, 15}));  // (hi - 1) * 2 + 1 - lo
  // Asked for no step (palpview's default), the volume is no finer than the CT: its nodes.
  const VolumePlan automatic = plan_volume(scene, {0, 256, true, false, true}, 1 << 20);
  EXPECT_EQ(automatic.step, 2u);
  EXPECT_EQ(automatic.dims, (std::array<std::int64_t, 3>{32, 32, 32}));
  EXPECT_EQ(plan_volume(coarse, {0, 256, true, false, true}, 1 << 20).step, 1u);
  // A grid that is not the CT's nor a refinement of it: no HU.
  scene.grid.dims[0] = 64;
  EXPECT_FALSE(plan_volume(scene, {1, 0, true, false, false}, 1 << 20).hu);
}

TEST(SceneMessages, NoHuWhenTheSceneHasNoCtAndRawWithoutDeflate) {
  SceneDescription scene = ct_scene();
  scene.ct = nullptr;
  const VolumePlan plan = plan_volume(scene, {1, 0, true, true, false}, 1 << 20);
  EXPECT_FALSE(plan.hu);
  EXPECT_TRUE(plan.bone);
  v1::VolumeChunk chunk;
  fill_volume_chunk(scene, plan, 0, 0, &chunk);
  EXPECT_TRUE(chunk.hu().empty());
  EXPECT_EQ(chunk.d_surf().size(), 32u * 32u * chunk.k_count() * 4u);
  EXPECT_EQ(chunk.d_bone().size(), chunk.d_surf().size());
}

// A client asking step 1 of a grid whose one slice exceeds a chunk's bound gets a coarser step:
// no chunk palpd sends is larger than kMaxChunkRawBytes.
TEST(SceneMessages, OneSliceNeverExceedsTheChunkBound) {
  SceneDescription scene = ct_scene();
  scene.ct = nullptr;
  scene.grid.dims = {4096, 4096, 10};
  const VolumePlan plan = plan_volume(scene, {1, 0, false, true, false}, 1 << 20);
  // 8 bytes a voxel: step 3 gives 1366^2 * 8 = 14.9 MB > 12 MiB, step 4 1024^2 * 8 = 8 MiB.
  EXPECT_EQ(plan.step, 4u);
  EXPECT_LE(static_cast<std::size_t>(plan.dims[0] * plan.dims[1]) * plan.voxel_bytes,
            kMaxChunkRawBytes);
}

}  // namespace
}  // namespace palp::net
