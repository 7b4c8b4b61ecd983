// The virtual coupling: its gains and the device damping Colgate and Schenkel's condition asks of
// them, free motion exactly free, a stiff model felt through the coupling's spring in series, a
// step in the model's force never passed on as a step, and a device that is never pulled.
#include "safety/virtual_coupling.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace palp {
namespace {

// A 1-D environment along z: a wall at z = 0 (inside: z < 0) of stiffness k (N/mm), plus a
// constant `step` (N) from the first touch, as the printed bone law adds at skin contact.
struct Wall {
  double k = 0.0, step = 0.0;
  Vec3d force(double z) const { return z < 0.0 ? Vec3d{0, 0, step - k * z} : Vec3d{}; }
  double stiffness(double z) const { return z < 0.0 ? k : 0.0; }
};

// Device held at depth z_device for `ticks` ticks at 1 kHz; the last force written.
Vec3d hold(CouplingState& s, const CouplingGains& g, const Wall& wall, double z_device, int ticks) {
  Vec3d f;
  for (int n = 0; n < ticks; ++n) {
    const double z_tool = coupled_tool(s, {0, 0, z_device}).z;
    f = couple(s, g, wall.force(z_tool), wall.stiffness(z_tool), {0, 0, z_device}, 0.001).force;
  }
  return f;
}

TEST(VirtualCoupling, GainsAreTheStableStiffnessAndTwiceItsTickInDamping) {
  for (const DeviceProfile& p : device_profiles()) {
    for (double rate : {500.0, 1000.0, 2000.0, 4000.0, 10000.0}) {
      const double t = 1.0 / rate;
      const CouplingGains g = coupling_gains(p, t);
      EXPECT_LE(g.stiffness_N_per_mm, p.max_stiffness_N_per_mm) << p.name << " " << rate;
      EXPECT_LE(g.damping_N_s_per_mm, p.damping_N_s_per_mm) << p.name << " " << rate;
      // B_c = 2 K_c (T + 2 t_d)
      const double lag = t + 2.0 * p.transport_delay_s;
      EXPECT_NEAR(g.damping_N_s_per_mm, 2.0 * g.stiffness_N_per_mm * lag, 1e-15) << p.name;
    }
  }
  // The Touch class at 1 kHz: K_c its 0.4 N/mm, B_c = 2 K_c T.
  const CouplingGains touch = coupling_gains(device_profile("touch"), 0.001);
  EXPECT_DOUBLE_EQ(touch.stiffness_N_per_mm, 0.4);
  EXPECT_DOUBLE_EQ(touch.damping_N_s_per_mm, 0.0008);
  // Where the device's damping caps B_c, K_c comes down with it.
  DeviceProfile weak = device_profile("touch");
  weak.damping_N_s_per_mm = 0.0004;
  const CouplingGains capped = coupling_gains(weak, 0.001);
  EXPECT_DOUBLE_EQ(capped.damping_N_s_per_mm, 0.0004);
  EXPECT_DOUBLE_EQ(capped.stiffness_N_per_mm, 0.2);
}

TEST(VirtualCoupling, ColgateSchenkelAsksMoreDampingThanTheDevicesHave) {
  // b > K T / 2 + |B| (Colgate & Schenkel 1997) with K = K_c and B = B_c = 2 K_c T: 2.5 K_c T.
  // Falcon class at 1 kHz, no delay: K_c = 3 N/mm = 3000 N/m, T = 1 ms: 1.5 + 6 = 7.5 N s/m.
  DeviceProfile undelayed = device_profile("falcon");
  undelayed.transport_delay_s = 0.0;
  const CouplingGains falcon = coupling_gains(undelayed, 0.001);
  EXPECT_NEAR(passive_device_damping(falcon, 0.001), 7.5e-3, 1e-15);
  // Touch class at 10 kHz: 400 N/m × 0.1 ms × 2.5 = 0.1 N s/m.
  const CouplingGains touch = coupling_gains(device_profile("touch"), 1e-4);
  EXPECT_NEAR(passive_device_damping(touch, 1e-4), 1e-4, 1e-18);
  // Two ticks of delay at 1 kHz add K_c × 2 ms = 6 N s/m for the Falcon class.
  EXPECT_NEAR(passive_device_damping(falcon, 0.001, 2), 13.5e-3, 1e-15);
  // The device damping the closed-loop studies assume (N s/mm; tests/bench/closed_loop.hpp) is
  // short of it at 1 kHz on every class: the coupling is not passive without a hand.
  const struct {
    const char* name;
    double b;
  } devices[] = {
      {"touch", 0.1e-3}, {"falcon", 0.5e-3}, {"phantom-premium", 0.2e-3}, {"omega", 1.0e-3}};
  for (const auto& d : devices) {
    const CouplingGains g = coupling_gains(device_profile(d.name), 0.001);
    EXPECT_LT(d.b, passive_device_damping(g, 0.001)) << d.name;
  }
}

TEST(VirtualCoupling, ATransportDelayWidensTheDamping) {
  // B_c = 2 K_c (T + 2 t_d). Touch class, 1 ms of delay at 1 kHz: 2 × 0.4 × 3 ms = 0.0024 N s/mm,
  // under its 0.004 cap: K_c stays 0.4.
  DeviceProfile touch = device_profile("touch");
  touch.transport_delay_s = 0.001;
  const CouplingGains t = coupling_gains(touch, 0.001);
  EXPECT_DOUBLE_EQ(t.stiffness_N_per_mm, 0.4);
  EXPECT_NEAR(t.damping_N_s_per_mm, 0.0024, 1e-15);
  // The Falcon class declares 2 ms: 2 × 3 × 5 ms = 0.03 N s/mm is over its 0.02 cap, so B_c =
  // 0.02 and K_c = 0.02 / (2 × 5 ms) = 2 N/mm.
  const CouplingGains f = coupling_gains(device_profile("falcon"), 0.001);
  EXPECT_NEAR(f.damping_N_s_per_mm, 0.02, 1e-15);
  EXPECT_NEAR(f.stiffness_N_per_mm, 2.0, 1e-12);
  // A non-finite or negative delay counts as none.
  touch.transport_delay_s = -1.0;
  EXPECT_NEAR(coupling_gains(touch, 0.001).damping_N_s_per_mm, 0.0008, 1e-15);
}

TEST(VirtualCoupling, FreeMotionIsExactlyFree) {
  const CouplingGains g = coupling_gains(device_profile("falcon"), 0.001);
  CouplingState s;
  for (int n = 0; n < 200; ++n) {
    const Vec3d device{30.0 * std::sin(n * 0.1), 5.0 * n, -2.0 * n};  // fast, in any direction
    EXPECT_EQ(coupled_tool(s, device), n == 0 ? device : s.tool);
    EXPECT_EQ(couple(s, g, {}, 0.0, device, 0.001).force, Vec3d{});
  }
}

TEST(VirtualCoupling, AStiffModelIsFeltThroughTheSpringInSeries) {
  // A 100 N/mm wall (the skin law's slope 10 mm deep is 5.4 N/mm; the bone cap's 30 N/mm), the
  // device pushed 1 mm in at 10 mm/s and held: the force settles where wall and coupling split the
  // millimetre, K_c K / (K_c + K) = 0.3984 N, and is never above the coupling's spring over the
  // depth plus its damper over twice the speed (the tool, a tick behind, bounces off the wall
  // once as the device moves on).
  const CouplingGains g = coupling_gains(device_profile("touch"), 0.001);
  const Wall wall{100.0, 0.0};
  CouplingState s;
  double largest = 0.0;
  for (int n = 0; n < 2000; ++n) {
    const double z = std::max(-1.0, 0.1 - 0.01 * n);
    const double f = hold(s, g, wall, z, 1).z;
    EXPECT_LE(f, 0.4 * std::max(0.0, -z) + 2.0 * 0.0008 * 10.0 + 1e-12) << n;
    largest = std::max(largest, f);
  }
  const double series = 0.4 * 100.0 / (0.4 + 100.0);
  EXPECT_NEAR(hold(s, g, wall, -1.0, 1).z, series, 1e-9);
  EXPECT_LE(largest, 0.4 + 0.016);
  EXPECT_NEAR(s.tool.z, -1.0 + series / 0.4, 1e-9);  // the tool rests 0.004 mm in
}

TEST(VirtualCoupling, AStepInTheModelIsNotPassedOn) {
  // 2.5 N from the first touch (the printed bone law 10 mm over a rib) on a soft wall: the device
  // pressed 1 mm past the surface gets the coupling's spring, not the 2.5 N step.
  const CouplingGains g = coupling_gains(device_profile("touch"), 0.001);
  const Wall wall{0.1, 2.5};
  CouplingState s;
  hold(s, g, wall, 0.5, 10);  // above the surface: free
  double largest = 0.0, previous = 0.0, largest_change = 0.0;
  for (int n = 0; n < 3000; ++n) {
    const double z = std::max(-1.0, 0.5 - 0.001 * n);  // 1 mm/s down to 1 mm deep
    const double f = hold(s, g, wall, z, 1).z;
    largest = std::max(largest, f);
    largest_change = std::max(largest_change, std::fabs(f - previous));
    previous = f;
  }
  EXPECT_LE(largest, 0.4 * 1.0 + 2.0 * 0.0008 * 1.0);  // K_c depth + 2 B_c speed at most
  EXPECT_LT(largest_change, 0.01);                     // 2.5 N would have come in one tick
  EXPECT_GT(largest, 0.35);
}

TEST(VirtualCoupling, NeverPullsTheDevice) {
  // Pressed 5 mm into a 1 N/mm wall, then pulled out at 200 mm/s: the force never points into
  // the wall, and is exactly 0 once the tool is out.
  const CouplingGains g = coupling_gains(device_profile("falcon"), 0.001);
  const Wall wall{1.0, 0.0};
  CouplingState s;
  hold(s, g, wall, -5.0, 500);
  for (int n = 0; n < 100; ++n) {
    const double z = -5.0 + 0.2 * n;
    const double z_tool = coupled_tool(s, {0, 0, z}).z;
    const Vec3d f =
        couple(s, g, wall.force(z_tool), wall.stiffness(z_tool), {0, 0, z}, 0.001).force;
    EXPECT_GE(f.z, 0.0) << n;
    if (z > 1.0) {
      EXPECT_EQ(f, Vec3d{}) << n;
    }
  }
}

TEST(VirtualCoupling, NonFiniteInputRestartsAtTheDevice) {
  const CouplingGains g = coupling_gains(device_profile("touch"), 0.001);
  CouplingState s;
  hold(s, g, Wall{1.0, 0.0}, -2.0, 10);
  const double nan = std::nan("");
  EXPECT_EQ(couple(s, g, {0, 0, nan}, 1.0, {0, 0, -2.0}, 0.001).force, Vec3d{});
  EXPECT_EQ(coupled_tool(s, {1, 2, 3}), (Vec3d{1, 2, 3}));
}

}  // namespace
}  // namespace palp
