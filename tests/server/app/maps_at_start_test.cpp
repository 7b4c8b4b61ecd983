// palpd's maps cut to its device's reach (server/app/maps_at_start.cpp): the reach boxes; a
// model on the window feels nothing past it (as outside the body, however deep inside the
// patient that point lies) and allocates nothing per tick, in or out of it; palpd with
// --map-window says what it keeps and reports it in Stats (palp probe).
#include "app/maps_at_start.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "model/force_model.hpp"
#include "scene/trajectory_gen.hpp"
#include "support/cli_test_util.hpp"
#include "support/heap_allocation_counter.hpp"
#include "support/palpd_process.hpp"

namespace palp {
namespace {

using app::Box;

TEST(MapsAtStart, ReachBoxes) {
  Registration r;  // device x -> scene y, y -> scene z, z -> scene x; scale 2; home (100, 0, 0)
  r.rotation = {0, 0, 1, 1, 0, 0, 0, 1, 0};
  r.scale = 2.0;
  r.home = {100.0, 0.0, 0.0};
  const Box b = app::placed_reach(r, {10.0, 20.0, 30.0});
  EXPECT_EQ(b.lo, (Vec3d{40.0, -20.0, -40.0}));
  EXPECT_EQ(b.hi, (Vec3d{160.0, 20.0, 40.0}));
  Trajectory path(3);
  path[0].pose.position = {1, 5, -2};
  path[1].pose.position = {-3, 2, 4};
  path[2].pose.position = {0, 9, 0};
  const Box p = app::path_reach(path);
  EXPECT_EQ(p.lo, (Vec3d{-3, 2, -2}));
  EXPECT_EQ(p.hi, (Vec3d{1, 9, 4}));
  // finger:1's one point sits the pad offset below the device point
  EXPECT_DOUBLE_EQ(app::tool_reach(parse_tool("finger:1")), pad_offset(parse_tool("finger:1")));
  EXPECT_GT(app::tool_reach(parse_tool("finger:37")), 1.0);
}

// A slab of tissue 40 mm thick (skin at z = 40, inside below), bone beneath at z = 10.
void slab(DistanceMap& surf, DistanceMap& bone) {
  Grid g;
  g.dims = {80, 80, 60};
  g.spacing = {1.0, 1.0, 1.0};
  surf = DistanceMap(g, 0.0f);
  bone = DistanceMap(g, 0.0f);
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        surf.at(i, j, k) = static_cast<float>(40.0 - static_cast<double>(k));
        bone.at(i, j, k) = static_cast<float>(10.0 - static_cast<double>(k));
      }
}

TEST(MapsAtStart, PastTheWindowTheToolFeelsNothingAndNoTickAllocates) {
  DistanceMap surf, bone;
  slab(surf, bone);
  const SamplerConfig config{GradientScheme::PrecomputedField, Storage::Float32};
  const auto whole = std::make_shared<const FieldSampler>(surf, bone, config);
  // The device reaches x, y in [20, 40], z in [30, 50]; the window holds that box widened by the
  // tool's reach (its point is 8 mm below the device point), as palpd's.
  const Tool tool = parse_tool("finger:1");
  const double r = app::tool_reach(tool);
  const MapWindow w = window_for_box(whole->grid(), Vec3d{20, 20, 30} - Vec3d{r, r, r},
                                     Vec3d{40, 40, 50} + Vec3d{r, r, r});
  const auto part = window_sampler(surf, bone, *whole, w, config);
  const Model a(whole, tool, palp_params(ToolKind::Finger));
  const Model b(part, tool, palp_params(ToolKind::Finger));
  State sa = make_state(a), sb = make_state(b);
  // Inside the window the two agree: pressing 5 mm at (30, 30).
  const Pose inside{{30.0, 30.0, 35.0}, Quat{}};
  tick(a, sa, inside);
  tick(b, sb, inside);
  EXPECT_GT(norm(sa.f_device), 0.5);
  EXPECT_NEAR(norm(sa.f_device - sb.f_device), 0.0, 1e-9);
  // Far past the window, 25 mm deep in the slab: the whole maps push, the window's sample as
  // outside the body (the value outside the grid) - no contact, no force.
  State fresh_a = make_state(a), fresh_b = make_state(b);
  const Pose beyond{{70.0, 70.0, 15.0}, Quat{}};
  g_allocations = 0;
  g_count_allocations = true;
  tick(a, fresh_a, beyond);
  tick(b, fresh_b, beyond);
  for (int t = 0; t < 2000; ++t) {  // in, out, back: no tick allocates
    const double x = 30.0 + 0.03 * t;
    tick(b, sb, Pose{{x, 30.0, 36.0}, Quat{}});
  }
  g_count_allocations = false;
  EXPECT_EQ(g_allocations.load(), 0);
  EXPECT_GT(norm(fresh_a.f_device), 1.0);
  EXPECT_EQ(fresh_b.n_contact, 0);
  EXPECT_EQ(norm(fresh_b.f_device), 0.0);
  EXPECT_EQ(part->sample_surf({70.0, 70.0, 15.0}).value, kOutsideValue);
  EXPECT_EQ(sb.n_contact, 0) << "left the window at x = 90 (it ends at x = 49): nothing felt there";
}

// palpd end to end: --map-window on the sim device's path keeps a window, says so, reports it.
TEST(MapsAtStart, PalpdKeepsTheWindowAndReportsIt) {
  namespace fs = std::filesystem;
  const fs::path log = testing::shared_cli_dir() / "palpd_maps.log";
  const int port = testing::start_palpd(
      "--scene phantom:sphere --device sim --no-realtime --port 0 --duration 3 --map-window 10",
      log);
  ASSERT_GT(port, 0) << testing::read_text(log);
  const auto probe =
      testing::run_palp_cli("probe 127.0.0.1:" + std::to_string(port) + " --duration 1.5",
                            testing::shared_cli_dir() / "cache");
  EXPECT_EQ(probe.exit_code, 0) << probe.output;
  EXPECT_NE(probe.output.find("  maps      maps cut to the device's reach + 10 mm: window "),
            std::string::npos)
      << probe.output;
  ASSERT_TRUE(testing::wait_palpd_exit(log)) << testing::read_text(log);
  const std::string text = testing::read_text(log);
  EXPECT_NE(text.find("x less)"), std::string::npos) << text;
  // A bad value is a usage error; a device whose reach is unknown keeps the whole maps.
  const std::string palpd = std::string("PALP_SCENE_CACHE='") +
                            (testing::shared_cli_dir() / "cache").string() + "' " + PALPD_PATH;
  auto r =
      testing::run_command(palpd + " --scene phantom:sphere --device sim --map-window far 2>&1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = testing::run_command(palpd +
                           " --scene phantom:sphere --device remote --no-realtime --port 0 "
                           "--duration 0.2 --map-window 10 2>&1");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("reach is not known: whole maps"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace palp
