// The passivity observer and controller: exact energies and damping, idle while passive.
#include "safety/passivity.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace palp {
namespace {

TEST(Passivity, PressingInStoresEnergyAndTheControllerStaysIdle) {
  // The hand pushes in (v = -10 mm/s along z) against 2 N outward for 1 ms: 0.02 mJ stored.
  const PassivityOutput o = passivity_control({}, {0, 0, 2}, {0, 0, -10}, 0.001, 0.02);
  EXPECT_DOUBLE_EQ(o.state.energy_mJ, 0.02);
  EXPECT_EQ(o.force, (Vec3d{0, 0, 2}));
  EXPECT_EQ(o.damping_N_s_per_mm, 0.0);
}

TEST(Passivity, ReturningMoreThanWasStoredIsDamped) {
  // 0.005 mJ stored; pushed out at 10 mm/s by 2 N for 1 ms returns 0.02 mJ: a deficit of 0.015.
  const PassivityOutput o = passivity_control({0.005}, {0, 0, 2}, {0, 0, 10}, 0.001, 1.0);
  // α = 0.015 / (100 · 0.001) = 0.15 N s/mm; F' = 2 - 0.15 · 10 = 0.5 N.
  EXPECT_NEAR(o.damping_N_s_per_mm, 0.15, 1e-12);
  EXPECT_NEAR(o.force.z, 0.5, 1e-12);
  EXPECT_NEAR(o.dissipated_mJ, 0.015, 1e-12);
  EXPECT_NEAR(o.state.energy_mJ, 0.0, 1e-15);
}

TEST(Passivity, DampingIsCappedByTheDevice) {
  const PassivityOutput o = passivity_control({-1.0}, {0, 0, 0}, {0, 0, 1}, 0.001, 0.02);
  EXPECT_EQ(o.damping_N_s_per_mm, 0.02);  // wants 1000
  EXPECT_NEAR(o.force.z, -0.02, 1e-15);
  EXPECT_LT(o.state.energy_mJ, 0.0);  // the rest waits for later ticks
}

TEST(Passivity, AtRestOrWithoutDampingNothingIsAdded) {
  const PassivityOutput rest = passivity_control({-1.0}, {0, 0, 3}, {0, 0, 0}, 0.001, 0.02);
  EXPECT_EQ(rest.force, (Vec3d{0, 0, 3}));
  const PassivityOutput observe = passivity_control({-1.0}, {0, 0, 3}, {0, 0, 1}, 0.001, 0.0);
  EXPECT_EQ(observe.force, (Vec3d{0, 0, 3}));
  EXPECT_NEAR(observe.state.energy_mJ, -1.003, 1e-12);
  const PassivityOutput nan = passivity_control({-1.0}, {0, 0, std::nan("")}, {0, 0, 1}, 0.001, 1);
  EXPECT_EQ(nan.state.energy_mJ, 0.0);
}

}  // namespace
}  // namespace palp
