// A window of a scene's maps (common/model/map_window.cpp): the voxels it keeps, the world
// placement it moves, and what it is for - a palp model on the window ticks as on the whole maps
// (to 1e-9 N: rounding), with every gradient scheme, anywhere inside the box, from a fraction of
// the memory.
#include "model/map_window.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "base/errors.hpp"
#include "model/force_model.hpp"
#include "prep/maps/distance_transform.hpp"

namespace palp {
namespace {

Grid grid() {
  Grid g;
  g.dims = {60, 50, 40};
  g.spacing = {1.0, 1.25, 2.0};
  g.world.origin = {-100.0, 50.0, 10.0};
  return g;
}

// Skin: a ball of radius 40 mm about (30, 30, 40); bone: a slab with two ribs on top of it.
void scene(DistanceMap& surf, DistanceMap& bone) {
  const Grid g = grid();
  surf = DistanceMap(g, 0.0f);
  Mask b(g, 0);
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const double x = i * g.spacing[0], y = j * g.spacing[1], z = k * g.spacing[2];
        surf.at(i, j, k) = static_cast<float>(
            40.0 - std::sqrt((x - 30) * (x - 30) + (y - 30) * (y - 30) + (z - 40) * (z - 40)));
        b.at(i, j, k) = (z > 20 && z < 26) || (z >= 26 && z < 34 && std::fmod(x, 20.0) < 6.0);
      }
  bone = signed_distance(b);
}

TEST(MapWindow, KeepsTheBoxesVoxelsAndMovesThePlacement) {
  const Grid g = grid();
  const MapWindow w = window_for_box(g, {10.2, 5.0, 20.0}, {20.7, 10.0, 21.0});
  // x: cells 10..20 -> voxels 10..21, one more each side: 9..22
  EXPECT_EQ(w.lo, (Index3{9, 3, 9}));
  EXPECT_EQ(w.dims, (Index3{14, 8, 4}));
  EXPECT_EQ(w.origin.x, 9.0);
  EXPECT_EQ(w.origin.y, 3 * 1.25);
  EXPECT_EQ(w.origin.z, 18.0);
  DistanceMap m(g, 0.0f);
  for (std::size_t v = 0; v < m.data.size(); ++v) m.data[v] = static_cast<float>(v);
  const DistanceMap c = crop(m, w);
  EXPECT_EQ(c.grid.dims, w.dims);
  EXPECT_EQ(c.at(0, 0, 0), m.at(9, 3, 9));
  EXPECT_EQ(c.at(13, 7, 3), m.at(22, 10, 12));
  EXPECT_EQ(c.grid.world.origin, (Vec3{-100.0 + 9.0, 50.0 + 3.75, 10.0 + 18.0}));
  // Clamped at the grid's edge; a box beside the grid is refused.
  const MapWindow edge = window_for_box(g, {-5.0, -5.0, -5.0}, {1.0, 1.0, 1.0});
  EXPECT_EQ(edge.lo, (Index3{0, 0, 0}));
  EXPECT_THROW(window_for_box(g, {500.0, 0, 0}, {600.0, 1, 1}), UsageError);
  EXPECT_THROW(window_for_box(g, {5.0, 0, 0}, {1.0, 1, 1}), UsageError);
}

TEST(MapWindow, APalpModelOnTheWindowTicksAsOnTheWholeMaps) {
  DistanceMap surf, bone;
  scene(surf, bone);
  const Vec3d lo{15.0, 15.0, 60.0}, hi{45.0, 45.0, 78.0};  // the device's reach, the pad in it
  for (GradientScheme scheme : {GradientScheme::PrecomputedField, GradientScheme::AnalyticTrilinear,
                                GradientScheme::CentralDifference}) {
    const SamplerConfig config{scheme, Storage::Float32};
    const auto whole = std::make_shared<const FieldSampler>(surf, bone, config);
    const Tool tool = parse_tool("finger:19");
    // The window must hold every contact point: the device box widened by the tool's reach.
    double reach = 0.0;
    for (const Vec3d& p : tool.points) reach = std::max(reach, norm(p));
    const MapWindow w = window_for_box(whole->grid(), lo - Vec3d{reach, reach, reach},
                                       hi + Vec3d{reach, reach, reach});
    const auto part = window_sampler(surf, bone, *whole, w, config);
    EXPECT_LT(part->grid().voxel_count() * 3, whole->grid().voxel_count());
    const Model a(whole, tool, palp_params(ToolKind::Finger));
    const Model b(part, tool, palp_params(ToolKind::Finger));
    State sa = make_state(a), sb = make_state(b);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> ux(lo.x, hi.x), uy(lo.y, hi.y), uz(lo.z, hi.z);
    int touching = 0;
    for (int t = 0; t < 3000; ++t) {
      // a wandering pose inside the box, the tool pointing down into the ball's top
      const Pose pose{{ux(rng), uy(rng), uz(rng)}, Quat{}};
      tick(a, sa, pose);
      tick(b, sb, pose);
      // Equal but for rounding: the window's cell fractions come from x - origin, not from x.
      ASSERT_NEAR(sa.f_device.x, sb.f_device.x, 1e-9) << to_string(scheme) << " tick " << t;
      ASSERT_NEAR(sa.f_device.y, sb.f_device.y, 1e-9) << t;
      ASSERT_NEAR(sa.f_device.z, sb.f_device.z, 1e-9) << t;
      touching += sa.n_contact > 0;
    }
    EXPECT_GT(touching, 500) << "the poses press the skin";
  }
}

}  // namespace
}  // namespace palp
