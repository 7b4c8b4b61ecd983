// The render volume palpd composes (server/net/scene_messages.cpp): the CT's HU and body mask at
// the step asked, deflated on request, and every chunk bounded whatever a client asks.
#include "net/scene_messages.hpp"

#include <gtest/gtest.h>

#include <cstring>

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
