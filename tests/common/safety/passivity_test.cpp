// The passivity observer and controller: the port energy summed by hand from its definition
// (E(n) = E(n-1) - (f_w(n-1) - f_a(n-1)) · (x(n) - x(n-1)), mJ = N·mm, f_a the known active
// input's part of the written force), the controller's damping, and a controller that does not
// credit itself.
#include "safety/passivity.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace palp {
namespace {

TEST(Passivity, TheObserverSumsTheWrittenForceAgainstTheTravel) {
  // Pressed in at 0.01 mm a tick against 2 N outward, three ticks: 3 × 0.02 mJ stored; then
  // pushed out 0.05 mm by 3 N: 0.15 mJ returned.
  PassivityState s;
  s = observe_port(s, {0, 0, 2}, {0, 0, -0.01});
  EXPECT_NEAR(s.energy_mJ, 0.02, 1e-15);
  s = observe_port(s, {0, 0, 2}, {0, 0, -0.01});
  s = observe_port(s, {0, 0, 2}, {0, 0, -0.01});
  EXPECT_NEAR(s.energy_mJ, 0.06, 1e-15);
  s = observe_port(s, {0, 0, 3}, {0, 0, 0.05});
  EXPECT_NEAR(s.energy_mJ, 0.06 - 0.15, 1e-15);
  // a lateral force against lateral travel counts too; travel across the force does not
  s = observe_port(s, {1, 0, 0}, {-0.2, 0.3, 0});
  EXPECT_NEAR(s.energy_mJ, -0.09 + 0.2, 1e-15);
}

TEST(Passivity, NoForceAddsNothingAndForgivesNothing) {
  PassivityState s{-0.4};
  for (int n = 0; n < 5; ++n) s = observe_port(s, {}, {0, 0, 1.0});
  EXPECT_EQ(s.energy_mJ, -0.4);
  // non-finite inputs add nothing either; a non-finite energy restarts at 0
  s = observe_port(s, {0, 0, std::nan("")}, {0, 0, 1.0});
  EXPECT_EQ(s.energy_mJ, -0.4);
  EXPECT_EQ(observe_port({std::nan("")}, {0, 0, 1}, {0, 0, 1}).energy_mJ, -1.0);
}

TEST(Passivity, ADeficitIsDampedWithoutCreditingTheController) {
  // E = -0.015 mJ; moving out at 10 mm/s for 1 ms under 2 N: α = 0.015 / (100 · 0.001) = 0.15
  // N s/mm, F' = 2 - 0.15 · 10 = 0.5 N, 0.015 mJ to dissipate.
  const PassivityState s{-0.015};
  const PassivityOutput o = passivity_control(s, {0, 0, 2}, {0, 0, 10}, 0.001, 1.0);
  EXPECT_NEAR(o.damping_N_s_per_mm, 0.15, 1e-12);
  EXPECT_NEAR(o.force.z, 0.5, 1e-12);
  EXPECT_NEAR(o.dissipated_mJ, 0.015, 1e-12);
  // Written and held while the device moves 0.01 mm out, the port sees 0.5 N · 0.01 mm = 0.005 mJ
  // returned (the undamped 2 N would have returned 0.02): nothing is credited beyond that.
  EXPECT_NEAR(observe_port(s, o.force, {0, 0, 0.01}).energy_mJ, -0.015 - 0.005, 1e-15);
}

TEST(Passivity, AKnownActiveInputsWorkIsLeftOut) {
  // 2.5 N written, 0.5 N of it the known active input, pressed in 0.01 mm: the passive 2 N stores
  // 0.02 mJ (the active 0.5 N's 0.005 mJ is the input's, not the environment's).
  PassivityState s;
  s = observe_port(s, {0, 0, 2.5}, {0, 0, -0.01}, {0, 0, 0.5});
  EXPECT_NEAR(s.energy_mJ, 0.02, 1e-15);
  // A pure source (all of the written force is active) adds nothing, whichever way the hand moves.
  for (double travel : {0.3, -0.7, 1.1})
    s = observe_port(s, {0.2, 0, 0.4}, {travel, 0, travel}, {0.2, 0, 0.4});
  EXPECT_EQ(s.energy_mJ, 0.02);
  // An active part on another axis than the passive force: only its own work is left out.
  s = observe_port(s, {1, 0, 2}, {0.1, 0, 0.05}, {1, 0, 0});
  EXPECT_NEAR(s.energy_mJ, 0.02 - 2 * 0.05, 1e-15);
  // A non-finite active part adds nothing.
  EXPECT_EQ(observe_port(s, {0, 0, 2}, {0, 0, 1}, {0, 0, std::nan("")}).energy_mJ, s.energy_mJ);
}

TEST(Passivity, APulseLeftInTheObserverReadsAsADeficit) {
  // Why the active part is left out: a pulse f = A (1 - cos θ) / 2 over a hand that yields a
  // quarter period late, z = -r sin θ, does ∮ f dz = A r π / 2 of work on it per beat. Left in
  // the port's sum, it drains E by that each beat (sampled: within 0.5 % at 1000 ticks a beat) and
  // the controller would damp the beat away; counted as the known input, E stays 0.
  const double a = 0.4, r = 1.5, pi = std::acos(-1.0);
  const int ticks = 1000, beats = 3;
  PassivityState left_in, known;
  double f_prev = 0.0, z_prev = 0.0;
  for (int n = 1; n <= ticks * beats; ++n) {
    const double theta = 2 * pi * n / ticks;
    const double z = -r * std::sin(theta);
    left_in = observe_port(left_in, {0, 0, f_prev}, {0, 0, z - z_prev});
    known = observe_port(known, {0, 0, f_prev}, {0, 0, z - z_prev}, {0, 0, f_prev});
    f_prev = a * (1 - std::cos(theta)) / 2;
    z_prev = z;
  }
  EXPECT_NEAR(left_in.energy_mJ, -beats * a * r * pi / 2, 0.005 * beats * a * r * pi / 2);
  EXPECT_EQ(known.energy_mJ, 0.0);
  EXPECT_GT(passivity_control(left_in, {0, 0, a}, {0, 0, 1}, 0.001, 1.0).damping_N_s_per_mm, 0.0);
  EXPECT_EQ(passivity_control(known, {0, 0, a}, {0, 0, 1}, 0.001, 1.0).damping_N_s_per_mm, 0.0);
}

TEST(Passivity, IdleWhilePassiveAtRestOrWithoutDamping) {
  const PassivityOutput passive = passivity_control({0.02}, {0, 0, 2}, {0, 0, 10}, 0.001, 1.0);
  EXPECT_EQ(passive.force, (Vec3d{0, 0, 2}));
  EXPECT_EQ(passive.damping_N_s_per_mm, 0.0);
  const PassivityOutput rest = passivity_control({-1.0}, {0, 0, 3}, {0, 0, 0}, 0.001, 0.02);
  EXPECT_EQ(rest.force, (Vec3d{0, 0, 3}));
  const PassivityOutput off = passivity_control({-1.0}, {0, 0, 3}, {0, 0, 1}, 0.001, 0.0);
  EXPECT_EQ(off.force, (Vec3d{0, 0, 3}));
  const PassivityOutput capped = passivity_control({-1.0}, {0, 0, 0}, {0, 0, 1}, 0.001, 0.02);
  EXPECT_EQ(capped.damping_N_s_per_mm, 0.02);  // wants 1000
  EXPECT_NEAR(capped.force.z, -0.02, 1e-15);
}

}  // namespace
}  // namespace palp
