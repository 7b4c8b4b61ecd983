// server/devices/falcon_kinematics.cpp against an independent transcription of libnifalcon's
// Stamper kinematics (tests/support/falcon_reference.hpp, each equation cited there): encoder ->
// angle, angles -> position (forward), position -> angles (inverse), force -> motor efforts, at a
// 9 x 9 x 9 grid over +-40 mm about the centre and at literal reference vectors. The expectations
// come from the transcription (and its literals), never from palp's kinematics.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include "devices/falcon_kinematics.hpp"
#include "support/falcon_reference.hpp"

namespace palp {
namespace {

namespace ref = falconref;

ref::V3 metres(const Vec3d& p_mm) {
  return {p_mm.x * 1e-3, p_mm.y * 1e-3, p_mm.z * 1e-3};
}
double at(const Vec3d& v, int i) {
  return i == 0 ? v.x : (i == 1 ? v.y : v.z);
}

// The grid, in palp's Falcon frame (mm): 9 x 9 x 9 points over +-40 mm about (0, 0, 110).
template <typename F>
void over_grid(F&& f) {
  for (int i = -4; i <= 4; ++i)
    for (int j = -4; j <= 4; ++j)
      for (int k = -4; k <= 4; ++k) f(Vec3d{10.0 * i, 10.0 * j, 110.0 + 10.0 * k});
}

// Reference vectors, printed once by falcon_reference.hpp (double precision, libnifalcon's
// truncated pi) and kept here as literals, so that neither side can drift: position (mm) ->
// theta1 of the three legs (rad).
struct AnglesVector {
  Vec3d p_mm;
  double theta1[3];
};
constexpr AnglesVector kAngles[] = {
    {{0.0, 0.0, 110.0}, {0.282533201336, 0.282533201336, 0.282533201336}},
    {{30.0, -20.0, 90.0}, {0.501838199540, -0.436271457955, 0.217992032464}},
    {{-35.0, 40.0, 140.0}, {0.375532561395, 1.255272553824, 0.992528314976}},
    {{0.0, 45.0, 75.0}, {-0.919447659936, 0.168664647900, 0.501523713948}},
};
// position (mm), force (N) -> motor efforts before any cap or rounding (STA getForces with the
// derived z column; libnifalcon's own 30 N m torque cap is not reached by these).
struct EffortVector {
  Vec3d p_mm, force;
  double effort[3];
};
constexpr EffortVector kEfforts[] = {
    {{0.0, 0.0, 110.0}, {0.0, 0.0, 5.0}, {-1209.008266, -1209.008261, -1209.008266}},
    {{30.0, -20.0, 90.0}, {2.0, -3.0, 1.0}, {-1983.081097, 355.150576, 101.475255}},
    {{-35.0, 40.0, 140.0}, {-4.0, 1.5, -2.5}, {2712.946044, -4140.690196, 2258.806364}},
    {{0.0, 45.0, 75.0}, {0.0, -8.0, 0.0}, {-1179.179571, 1155.810188, 3009.440937}},
};

TEST(FalconReference, TranscriptionReproducesItsLiteralVectors) {
  for (const auto& v : kAngles) {
    ref::Angles q;
    ASSERT_TRUE(ref::ik(metres(v.p_mm), q));
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(q.theta1[i], v.theta1[i], 1e-11);
  }
  for (const auto& v : kEfforts) {
    ref::V3 e;
    ASSERT_TRUE(ref::efforts(metres(v.p_mm), {v.force.x, v.force.y, v.force.z}, e));
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(e[i], v.effort[i], 1e-5);
  }
  EXPECT_NEAR(ref::theta_deg(0), 35.0, 1e-12);
  EXPECT_NEAR(ref::theta_deg(2200), 115.15625, 1e-9);
}

// The Jacobian's z column: libnifalcon prints sin(theta2)^2 / den (STA:113); differentiating its
// own inverse kinematics gives sin(theta2) sin(theta3) / den. Central differences of the
// transcribed inverse kinematics decide: the derived form within 1e-5, the printed one off by
// more than 10 % somewhere (at the centre sin(theta2) = 0.75, sin(theta3) = 1.00).
TEST(FalconReference, DerivedJacobianMatchesFiniteDifferencesThePrintedOneDoesNot) {
  const double h = 1e-7;  // m
  double derived = 0.0, printed = 0.0;
  over_grid([&](const Vec3d& p_mm) {
    const ref::V3 p = metres(p_mm);
    ref::Angles q;
    ASSERT_TRUE(ref::ik(p, q));
    const ref::M3 Jd = ref::dtheta_dp(q, ref::JzForm::Derived);
    const ref::M3 Jp = ref::dtheta_dp(q, ref::JzForm::Printed);
    for (int c = 0; c < 3; ++c) {
      ref::V3 plus = p, minus = p;
      plus[c] += h;
      minus[c] -= h;
      ref::Angles qp, qm;
      ASSERT_TRUE(ref::ik(plus, qp) && ref::ik(minus, qm));
      for (int r = 0; r < 3; ++r) {
        const double fd = (qp.theta1[r] - qm.theta1[r]) / (2 * h);
        const double scale = std::max(std::abs(fd), 1.0);  // rad/m
        derived = std::max(derived, std::abs(Jd[r][c] - fd) / scale);
        printed = std::max(printed, std::abs(Jp[r][c] - fd) / scale);
      }
    }
  });
  EXPECT_LT(derived, 1e-5);
  EXPECT_GT(printed, 0.1);
}

TEST(FalconReference, EncoderAnglesAgree) {
  for (const int e : {-3000, -517, 0, 1, 2500})
    EXPECT_NEAR(falcon::joint_angle(e), ref::theta_deg(e) * ref::kDegToRad, 1e-8) << e;
}

// Position -> angles. Tolerance 1e-7 rad: libnifalcon's pi is 3.14159265 (GEO:34), which moves
// the leg directions by ~4e-9 rad.
TEST(FalconReference, InverseKinematicsAgreesOverTheWorkspace) {
  double worst = 0.0;
  over_grid([&](const Vec3d& p) {
    ref::Angles q;
    Vec3d t;
    ASSERT_TRUE(ref::ik(metres(p), q));
    ASSERT_TRUE(falcon::inverse(p, t));
    for (int i = 0; i < 3; ++i) worst = std::max(worst, std::abs(at(t, i) - q.theta1[i]));
  });
  EXPECT_LT(worst, 1e-7);
  for (const auto& v : kAngles) {
    Vec3d t;
    ASSERT_TRUE(falcon::inverse(v.p_mm, t));
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(at(t, i), v.theta1[i], 1e-7);
  }
}

// Angles -> position. The reference's angles (from its inverse kinematics) through palp's forward
// kinematics come back to the reference's position within 1e-3 mm (1e-7 rad of pi truncation
// times ~100 mm of arm, plus Newton's 1e-9 rad stop); the reference's own forward kinematics
// (STA's Newton-Raphson, asked for 1e-10 rad) agree as well.
TEST(FalconReference, ForwardKinematicsAgreesOverTheWorkspace) {
  double worst_palp = 0.0, worst_ref = 0.0;
  over_grid([&](const Vec3d& p) {
    ref::Angles q;
    ASSERT_TRUE(ref::ik(metres(p), q));
    Vec3d back;
    ASSERT_TRUE(
        falcon::forward({q.theta1[0], q.theta1[1], q.theta1[2]}, falcon::kWorkspaceCentre, back));
    worst_palp = std::max(worst_palp, norm(back - p));
    ref::V3 guess{0.0, 0.0, 0.110};
    ASSERT_TRUE(ref::fk({q.theta1[0], q.theta1[1], q.theta1[2]}, guess, 1e-10, 60));
    worst_ref = std::max(worst_ref, norm(Vec3d{guess[0], guess[1], guess[2]} * 1e3 - p));
  });
  EXPECT_LT(worst_palp, 1e-3);
  EXPECT_LT(worst_ref, 1e-3);
  for (const auto& v : kAngles) {
    Vec3d back;
    ASSERT_TRUE(
        falcon::forward({v.theta1[0], v.theta1[1], v.theta1[2]}, falcon::kWorkspaceCentre, back));
    EXPECT_LT(norm(back - v.p_mm), 1e-3);
  }
}

// palp's efforts against the reference's unrounded ones: within 0.5 count + 1e-3 (palp rounds)
// where no motor passes the cap; beyond it, the reference's vector scaled so its largest is the
// cap, within 1 count (the direction kept, not clipped motor by motor).
void expect_efforts_match(const Vec3d& p, const Vec3d& force, const ref::V3& raw) {
  const falcon::Efforts e = falcon::efforts_for_force(p, force);
  const double largest = std::max({std::abs(raw[0]), std::abs(raw[1]), std::abs(raw[2])});
  const double cap = ref::kDocumentedEffortCap;
  const double scale = largest > cap ? cap / largest : 1.0;
  EXPECT_EQ(e.clamped, largest > cap);
  for (int i = 0; i < 3; ++i)
    EXPECT_NEAR(double(e.value[std::size_t(i)]), raw[i] * scale, scale < 1.0 ? 1.0 : 0.501)
        << "p (" << p.x << ", " << p.y << ", " << p.z << ") F (" << force.x << ", " << force.y
        << ", " << force.z << ") motor " << i;
}

TEST(FalconReference, EffortsAgreeOverTheWorkspace) {
  const Vec3d forces[] = {{0, 0, 5}, {3, 0, 0}, {0, -4, 0}, {2, -3, 1}, {-6, 4, -5}, {0, 0, -12}};
  int limited = 0, cases = 0;
  over_grid([&](const Vec3d& p) {
    for (const Vec3d& f : forces) {
      ref::V3 raw;
      ASSERT_TRUE(ref::efforts(metres(p), {f.x, f.y, f.z}, raw));
      expect_efforts_match(p, f, raw);
      limited += std::max({std::abs(raw[0]), std::abs(raw[1]), std::abs(raw[2])}) > 4095.0;
      ++cases;
    }
  });
  EXPECT_EQ(cases, 729 * 6);
  EXPECT_GT(limited, 0);  // both branches were exercised
  EXPECT_LT(limited, cases);
  for (const auto& v : kEfforts)
    expect_efforts_match(v.p_mm, v.force, {v.effort[0], v.effort[1], v.effort[2]});
}

// The emulator and this transcription include none of palp's Falcon headers: a wrong bit, sign
// or length in palp cannot pass by being shared.
TEST(FalconReference, EmulatorAndReferenceIncludeNoPalpFalconHeader) {
  for (const char* file :
       {"tests/support/falcon_reference.hpp", "tests/support/falcon_emulator.hpp",
        "tests/support/falcon_emulator.cpp"}) {
    std::ifstream in(std::string(PALP_SOURCE_DIR) + "/" + file);
    ASSERT_TRUE(in) << file;
    std::string line;
    while (std::getline(in, line)) {
      if (line.rfind("#include", 0) != 0) continue;
      EXPECT_EQ(line.find("usb/falcon_protocol.hpp"), std::string::npos) << file << ": " << line;
      EXPECT_EQ(line.find("falcon_kinematics.hpp"), std::string::npos)
          << file << ": " << line;
    }
  }
}

}  // namespace
}  // namespace palp
