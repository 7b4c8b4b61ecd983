// The ribs and intercostal spaces of find_landmarks (common/anatomy/ribs.cpp, rib_landmarks.cpp):
// tiny synthetic trunks for each numbering rule, the trunk phantom against its truth
// (io/phantom_trunk.hpp) in three storage orientations, and the shared CT by anatomy (skipped
// when ../shared/data is absent).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "anatomy/landmark_detection.hpp"
#include "anatomy/trunk_truth.hpp"
#include "base/patient_frame.hpp"
#include "io/phantom.hpp"
#include "prep/prep.hpp"

namespace palp::anatomy {
namespace {

constexpr double kVoxelMm = 2.0;

// A box-shaped body (x 0..240, y 0..200 mm) on a 2 mm LPS grid: a sacrum block and vertebrae
// (40 x 30 mm bodies centred at x 120, y 100, 24 mm tall over 8 mm discs) from the bottom up,
// and ribs painted as tubes.
struct Trunk {
  LandmarkInputs in;
  Trunk() {
    Grid g;
    g.dims = {120, 100, 175};
    g.spacing = {kVoxelMm, kVoxelMm, kVoxelMm};
    in.scene = "synthetic";
    in.bone = Mask(g, 0);
    in.body = Mask(g, 0);
    in.d_surf = DistanceMap(g, 0.0f);
    for (std::int64_t k = 0; k < g.dims[2]; ++k)
      for (std::int64_t j = 0; j < g.dims[1]; ++j)
        for (std::int64_t i = 0; i < g.dims[0]; ++i) {
          const double inside = std::min({double(i - 2), double(g.dims[0] - 3 - i),
                                          double(j - 2), double(g.dims[1] - 3 - j)}) *
                                kVoxelMm;
          in.body.at(i, j, k) = inside >= 0.0;
          in.d_surf.at(i, j, k) = static_cast<float>(inside + 1.0);
        }
  }
  void box(double x0, double x1, double y0, double y1, double z0, double z1) {
    const Grid& g = in.bone.grid;
    for (std::int64_t k = 0; k < g.dims[2]; ++k)
      for (std::int64_t j = 0; j < g.dims[1]; ++j)
        for (std::int64_t i = 0; i < g.dims[0]; ++i) {
          const double x = i * kVoxelMm, y = j * kVoxelMm, z = k * kVoxelMm;
          if (x >= x0 && x <= x1 && y >= y0 && y <= y1 && z >= z0 && z <= z1)
            in.bone.at(i, j, k) = 1;
        }
  }
  void tube(const std::vector<Vec3d>& line, double radius) {
    const Grid& g = in.bone.grid;
    for (std::size_t n = 0; n + 1 < line.size(); ++n) {
      const Vec3d a = line[n], b = line[n + 1];
      const double length = norm(b - a);
      for (double s = 0.0; s <= length; s += 0.5) {
        const Vec3d c = a + (b - a) * (s / length);
        for (double dz = -radius; dz <= radius; dz += 0.5)
          for (double dy = -radius; dy <= radius; dy += 0.5)
            for (double dx = -radius; dx <= radius; dx += 0.5) {
              if (dx * dx + dy * dy + dz * dz > radius * radius) continue;
              const auto i = std::lround((c.x + dx) / kVoxelMm);
              const auto j = std::lround((c.y + dy) / kVoxelMm);
              const auto k = std::lround((c.z + dz) / kVoxelMm);
              if (i >= 0 && j >= 0 && k >= 0 && i < g.dims[0] && j < g.dims[1] && k < g.dims[2])
                in.bone.at(i, j, k) = 1;
            }
      }
    }
  }
  // The vertebra `v` above the sacrum (1 = L5): its body's z range.
  static double z_lo(int v) { return 40.0 + 8.0 + (v - 1) * 32.0; }
  void column(bool sacrum, int vertebrae) {
    if (sacrum) box(55, 185, 85, 115, 0, 40);
    for (int v = 1; v <= vertebrae; ++v) {
      const double z0 = z_lo(v);
      box(100, 140, 85, 115, z0, z0 + 24.0);
      box(116, 124, 130, 165, z0 + 5.0, z0 + 19.0);
    }
  }
  // A rib on side (-1 right, +1 left) with its head at vertebra v's upper part: the neck back
  // to the tubercle, then around the body (centre x 120, y 99; radii 95 x 75 mm) from 60 degrees
  // behind the mid-axillary line forward to `end_deg` (negative: in front), descending 15 mm to
  // the MAL; returns the MAL's crossing (or nothing when it ends behind it).
  std::optional<Vec3d> rib(int side, int v, double end_deg) {
    const double s = side, zh = z_lo(v) + 0.8 * 24.0;
    std::vector<Vec3d> line{{120 + s * 30, 105, zh}, {120 + s * 38, 135, zh - 1}};
    std::optional<Vec3d> mal;
    for (double t = 60.0;; t -= 5.0) {
      const double tt = std::max(t, end_deg), r = tt * std::numbers::pi / 180.0;
      const double z = zh - 3.0 - 15.0 * (60.0 - tt) / 60.0;
      line.push_back({120 + s * 95 * std::cos(r), 99 + 75 * std::sin(r), z});
      if (std::abs(tt) < 1e-9) mal = line.back();
      if (tt <= end_deg) break;
    }
    tube(line, 5.0);
    return mal;
  }
};

const IntercostalSpace* space(const Landmarks& lm, Side side, int upper) {
  return find_intercostal_space(lm, side, upper);
}

TEST(Ribs, NumberedByTheVertebraAtTheirHeadWithASpaceAtTheMidAxillaryLine) {
  Trunk t;
  t.column(true, 8);  // L5..L1, T12, T11, T10
  std::optional<Vec3d> mal[2][3];
  for (int s = 0; s < 2; ++s) {
    mal[s][0] = t.rib(s ? 1 : -1, 8, -40.0);  // T10
    mal[s][1] = t.rib(s ? 1 : -1, 7, -40.0);  // T11
    mal[s][2] = t.rib(s ? 1 : -1, 6, 30.0);   // T12: ends behind the MAL
  }
  const Landmarks lm = find_landmarks(t.in);
  ASSERT_NE(find_vertebra(lm, "T12"), nullptr);
  for (Side side : {Side::right, Side::left}) {
    for (int n : {10, 11, 12}) {
      const Rib* r = find_rib(lm, side, n);
      ASSERT_NE(r, nullptr) << side_name(side) << " rib " << n;
      EXPECT_GT(r->confidence, 0.5);
      EXPECT_GE(r->points.size(), 5u);
    }
    const int s = side == Side::right ? 0 : 1;
    const IntercostalSpace* ten = space(lm, side, 10);
    ASSERT_NE(ten, nullptr);
    ASSERT_TRUE(ten->skin_point) << ten->reason;
    // On the body's lateral face (d_surf's zero at x 3 and 235 mm), midway between the crossings.
    EXPECT_NEAR(ten->skin_point->x, s ? 235.0 : 3.0, 1.0);
    EXPECT_NEAR(ten->skin_point->z, 0.5 * (mal[s][0]->z + mal[s][1]->z), 3.0);
    ASSERT_TRUE(ten->normal);
    EXPECT_GT(std::fabs(ten->normal->x), 0.9);
    const IntercostalSpace* eleven = space(lm, side, 11);
    ASSERT_NE(eleven, nullptr);
    EXPECT_FALSE(eleven->skin_point);
    EXPECT_NE(eleven->reason.find("rib 12 ends"), std::string::npos) << eleven->reason;
    EXPECT_NE(eleven->reason.find("behind the mid-axillary line"), std::string::npos);
  }
}

TEST(Ribs, LowestRibOnL1KeepsTheSacrumsNamesWithLessConfidence) {
  const auto landmarks = [](int lowest) {
    Trunk t;
    t.column(true, 7);  // L5..L1, T12, T11
    for (int s : {-1, 1})
      for (int v = lowest; v <= 7; ++v) t.rib(s, v, -40.0);
    return find_landmarks(t.in);
  };
  const Landmarks usual = landmarks(6), lumbar = landmarks(5);  // lowest on T12 / on L1
  const Rib* usual_12 = find_rib(usual, Side::right, 12);
  ASSERT_NE(usual_12, nullptr);
  EXPECT_TRUE(usual_12->reason.empty()) << usual_12->reason;
  // The names stay the sacrum's: the rib on T12 is still the 12th, less sure.
  const Rib* rib_12 = find_rib(lumbar, Side::right, 12);
  ASSERT_NE(rib_12, nullptr);
  EXPECT_LT(rib_12->confidence, usual_12->confidence);
  EXPECT_NE(rib_12->reason.find("T12"), std::string::npos) << rib_12->reason;
  // The rib on L1 has no number, and says why.
  int unnumbered = 0;
  for (const Rib& r : lumbar.ribs)
    if (!r.number) {
      ++unnumbered;
      EXPECT_NE(r.reason.find("L1"), std::string::npos) << r.reason;
      EXPECT_NE(r.reason.find("lumbar rib"), std::string::npos) << r.reason;
    }
  EXPECT_EQ(unnumbered, 2);
  ASSERT_NE(find_vertebra(lumbar, "L1"), nullptr);
  bool noted = false;
  for (const std::string& n : lumbar.notes) noted |= n.find("lowest rib") != std::string::npos;
  EXPECT_TRUE(noted);
}

TEST(Ribs, SlabWithoutSacrumOrRiblessVertebraGivesRibsNoNumbers) {
  Trunk t;
  t.column(false, 3);
  for (int s : {-1, 1}) t.rib(s, 1, -40.0), t.rib(s, 2, -40.0), t.rib(s, 3, -40.0);
  const Landmarks lm = find_landmarks(t.in);
  EXPECT_EQ(lm.ribs.size(), 6u);
  for (const Rib& r : lm.ribs) {
    EXPECT_FALSE(r.number);
    EXPECT_FALSE(r.reason.empty());
  }
  EXPECT_TRUE(lm.intercostal_spaces.empty());
}

// --- the trunk phantom --------------------------------------------------------------------

double to_segment(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
  const Vec3d ab = b - a;
  const double t = std::clamp(dot(p - a, ab) / std::max(dot(ab, ab), 1e-12), 0.0, 1.0);
  return norm(p - (a + ab * t));
}
double to_polyline(const Vec3d& p, const std::vector<Vec3d>& line) {
  double best = 1e30;
  for (std::size_t n = 0; n + 1 < line.size(); ++n)
    best = std::min(best, to_segment(p, line[n], line[n + 1]));
  return best;
}

void expect_ribs_match_truth(const std::string& orient) {
  const std::string input = orient.empty() ? "phantom:trunk" : "phantom:trunk,orient=" + orient;
  const std::string dir = (std::filesystem::temp_directory_path() /
                           ("palp-ribs-trunk-" + (orient.empty() ? "LPS" : orient)))
                              .string();
  PrepParams params;
  params.use_cache = false;
  params.find_vessels = false;  // as landmark_detection_test: it claims thoracic bone
  run_prep(input, dir, params);
  const Landmarks lm = find_landmarks(read_landmark_inputs(dir, input));
  PhantomOptions options;
  if (!orient.empty()) options.orient = orient;
  const Landmarks truth = trunk_landmark_truth(options);
  ASSERT_EQ(truth.ribs.size(), 10u);
  for (const Rib& want : truth.ribs) {
    const Rib* got = find_rib(lm, want.side, *want.number);
    ASSERT_NE(got, nullptr) << side_name(want.side) << " rib " << *want.number;
    double worst = 0.0;
    std::vector<double> off;
    for (const Vec3d& p : got->points) off.push_back(to_polyline(p, want.points));
    for (double d : off) worst = std::max(worst, d);
    std::nth_element(off.begin(), off.begin() + static_cast<std::ptrdiff_t>(off.size() / 2),
                     off.end());
    // The line reaches the rib's end: the truth's last point is near the found line.
    const double end = to_polyline(want.points.back(), got->points);
    std::printf(
        "%s %s rib %d: %zu points, median %.1f worst %.1f mm from the truth, its end %.1f mm\n",
        orient.c_str(), side_name(want.side), *want.number, got->points.size(),
        off[off.size() / 2], worst, end);
    EXPECT_LE(worst, 5.0);
    EXPECT_LE(end, 8.0);
    EXPECT_GT(got->confidence, 0.5);
  }
  EXPECT_EQ(lm.ribs.size(), truth.ribs.size());
  for (const IntercostalSpace& want : truth.intercostal_spaces) {
    const IntercostalSpace* got = find_intercostal_space(lm, want.side, *want.upper_rib);
    ASSERT_NE(got, nullptr) << side_name(want.side) << " space " << *want.upper_rib;
    if (!want.skin_point) {
      EXPECT_FALSE(got->skin_point);
      EXPECT_FALSE(got->reason.empty());
      std::printf("%s %s space %d: none (%s)\n", orient.c_str(), side_name(want.side),
                  *want.upper_rib, got->reason.c_str());
      continue;
    }
    ASSERT_TRUE(got->skin_point) << got->reason;
    const double d = norm(*got->skin_point - *want.skin_point);
    const double angle = std::acos(std::clamp(dot(*got->normal, *want.normal), -1.0, 1.0));
    std::printf("%s %s space %d: %.1f mm, normal %.1f deg\n", orient.c_str(),
                side_name(want.side), *want.upper_rib, d, angle * 180.0 / std::numbers::pi);
    EXPECT_LE(d, 5.0);
    EXPECT_LE(angle * 180.0 / std::numbers::pi, 10.0);
  }
}

TEST(Ribs, TrunkPhantomRibsAndSpacesMatchTheTruth) {
  expect_ribs_match_truth("");
}
TEST(Ribs, TrunkPhantomStoredRasRibsAndSpacesMatchTheTruth) {
  expect_ribs_match_truth("RAS");
}
TEST(Ribs, TrunkPhantomStoredPermutedRibsAndSpacesMatchTheTruth) {
  expect_ribs_match_truth("SLP");
}

// --- the shared CT --------------------------------------------------------------------------

// The lower chest of a real CT (ribs 7-12, the scan's top at T12): the 12th ribs' heads at
// T12, the ribs above cut by the scan's top edge and numbered by their order; spaces on the skin.
TEST(Ribs, SharedCtRibsNumberedOnBothSidesAndSpacesOnTheSkin) {
  const std::string ct = std::string(PALP_SHARED_DATA_DIR) + "/ct_abdomen_3mm.nii.gz";
  if (!std::filesystem::exists(ct)) GTEST_SKIP() << ct << " absent";
  const std::string dir =
      (std::filesystem::temp_directory_path() / "palp-ribs-shared-ct").string();
  run_prep(ct, dir, PrepParams{});
  const LandmarkInputs in = read_landmark_inputs(dir, ct);
  const Landmarks lm = find_landmarks(in);
  for (Side side : {Side::right, Side::left}) {
    for (int n : {10, 11, 12}) {
      const Rib* r = find_rib(lm, side, n);
      EXPECT_NE(r, nullptr) << side_name(side) << " rib " << n;
      if (r) std::printf("%s rib %d: %zu points, confidence %.2f\n", side_name(side), n,
                         r->points.size(), r->confidence);
    }
  }
  // The 12th ribs' heads lie at T12 (the count from the sacrum holds): no note says otherwise.
  for (const std::string& note : lm.notes) EXPECT_EQ(note.find("lowest rib"), std::string::npos);
  int on_skin = 0;
  for (const IntercostalSpace& s : lm.intercostal_spaces) {
    if (!s.skin_point) {
      EXPECT_FALSE(s.reason.empty());
      continue;
    }
    ++on_skin;
    const Vec3d scene = scene_of_world(in.d_surf.grid, *s.skin_point);
    const auto i = std::lround(scene.x / in.d_surf.grid.spacing[0]);
    const auto j = std::lround(scene.y / in.d_surf.grid.spacing[1]);
    const auto k = std::lround(scene.z / in.d_surf.grid.spacing[2]);
    EXPECT_LE(std::fabs(in.d_surf.at(i, j, k)), 2.0 + in.d_surf.grid.max_spacing());
    std::printf("%s space %d on the skin\n", side_name(s.side), *s.upper_rib);
  }
  EXPECT_GE(on_skin, 1);
}

}  // namespace
}  // namespace palp::anatomy
