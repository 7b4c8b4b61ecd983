// The search path (the scripted trainee of palp traj search) on the trunk phantom against its
// truth: the pad keeps its depth and the local normal over the curved skin, the hold ends on the
// target (or the miss superior of it), the same patient stored RAS gives the same path in the
// patient's frame, the same inputs the same rows, and bad inputs are refused.
#include "scene/search_path.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <numbers>
#include <string>

#include "anatomy/trunk_truth.hpp"
#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "scene/path_geometry.hpp"
#include "scene/scene.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;

class Search : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    cache_ = fs::temp_directory_path() / ("palp-search-test-" + std::to_string(::getpid()));
    SceneOptions options;
    options.cache_dir = cache_.string();
    lps_ = std::make_unique<Scene>(load_scene("phantom:trunk", options));
    ras_ = std::make_unique<Scene>(load_scene("phantom:trunk,orient=RAS", options));
  }
  static void TearDownTestSuite() {
    lps_.reset();
    ras_.reset();
    std::error_code ec;
    fs::remove_all(cache_, ec);
  }
  static inline fs::path cache_;
  static inline std::unique_ptr<Scene> lps_, ras_;
};

constexpr double kOffset = 8.0;  // finger:N

SearchTarget ninth_space() {
  const anatomy::Landmarks truth = anatomy::trunk_landmark_truth();
  const anatomy::IntercostalSpace* s =
      anatomy::find_intercostal_space(truth, anatomy::Side::right, 9);
  return {*s->skin_point, *s->normal};
}

Vec3d pad_centre(const Pose& pose) {
  return pose.position + rotate(pose.orientation, Vec3d{0.0, 0.0, -kOffset});
}

double angle_deg(const Vec3d& a, const Vec3d& b) {
  const double c = dot(a, b) / (norm(a) * norm(b));
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / std::numbers::pi;
}

TEST_F(Search, ThePadKeepsItsDepthAndTheLocalNormalFromTheStartToTheMark) {
  SearchSpec spec;
  spec.misses_mm = {0.0, 20.0};
  const SearchPath path = search_path(*lps_->fields, ninth_space(), kOffset, spec);
  ASSERT_EQ(path.mark_times_s.size(), 2u);
  // Trial 1: approach 1 s, slide 25 mm at 10 mm/s, hold 1 s (mark mid-hold), lift 1 s.
  EXPECT_DOUBLE_EQ(path.mark_times_s[0], 4.0);
  const Trajectory& rows = path.trajectory;
  for (std::size_t i = 0; i < rows.size(); ++i)
    ASSERT_DOUBLE_EQ(rows[i].t, static_cast<double>(i) / 1000.0) << i;
  // From the end of the press (t = 1) to the start of the lift (t = 4.5): at 4 mm, +z outward.
  int checked = 0;
  for (const TrajectorySample& row : rows) {
    if (row.t < 1.0 || row.t > 4.5) continue;
    const Vec3d pad = pad_centre(row.pose);
    EXPECT_NEAR(lps_->fields->sample_surf(pad).value, spec.depth_mm, 0.05) << row.t;
    const Vec3d normal = path_geometry::patch_normal(
        *lps_->fields, pad + spec.depth_mm * rotate(row.pose.orientation, {0, 0, 1}), {0, 0, 1});
    EXPECT_LT(angle_deg(rotate(row.pose.orientation, {0, 0, 1}), normal), 5.0) << row.t;
    ++checked;
  }
  EXPECT_EQ(checked, 3501);
  // The ends on the skin: the target itself, and 20 mm along the skin toward superior.
  const SearchTarget target = ninth_space();
  const Vec3d end0 = world_of_scene(lps_->grid, path.end_points_scene[0]);
  const Vec3d end1 = world_of_scene(lps_->grid, path.end_points_scene[1]);
  EXPECT_LT(norm(end0 - target.point_lps), 1.0);
  EXPECT_NEAR(end1.z - target.point_lps.z, 20.0, 1.0);
  EXPECT_LT(std::fabs(end1.y - target.point_lps.y), 2.0);
}

TEST_F(Search, TheSamePatientStoredRasGivesTheSamePathInThePatientsFrame) {
  SearchSpec spec;
  spec.rate_hz = 200.0;
  spec.misses_mm = {-10.0};
  const SearchPath a = search_path(*lps_->fields, ninth_space(), kOffset, spec);
  const SearchPath b = search_path(*ras_->fields, ninth_space(), kOffset, spec);
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < a.trajectory.size(); ++i) {
    const Vec3d pa = world_of_scene(lps_->grid, a.trajectory[i].pose.position);
    const Vec3d pb = world_of_scene(ras_->grid, b.trajectory[i].pose.position);
    worst = std::max(worst, norm(pa - pb));
  }
  EXPECT_LT(worst, 0.5) << "mm between the two storage orders' device points";
}

TEST_F(Search, TheSameInputsTheSameRows) {
  SearchSpec spec;
  spec.rate_hz = 250.0;
  spec.misses_mm = {0.0, 13.0, -26.0};
  const SearchPath a = search_path(*lps_->fields, ninth_space(), kOffset, spec);
  const SearchPath b = search_path(*lps_->fields, ninth_space(), kOffset, spec);
  ASSERT_EQ(format_trajectory_csv(a.trajectory), format_trajectory_csv(b.trajectory));
  EXPECT_EQ(a.mark_times_s, b.mark_times_s);
  ASSERT_EQ(a.mark_times_s.size(), 3u);
  // Each mark on a row's time, strictly later than the one before.
  for (std::size_t k = 0; k < 3; ++k) {
    const auto row = std::find_if(a.trajectory.begin(), a.trajectory.end(),
                                  [&](const auto& r) { return r.t == a.mark_times_s[k]; });
    EXPECT_NE(row, a.trajectory.end()) << k;
    if (k > 0) {
      EXPECT_GT(a.mark_times_s[k], a.mark_times_s[k - 1]);
    }
  }
}

TEST_F(Search, RefusesATargetOffThisSkinAndBadSpecs) {
  SearchTarget far = ninth_space();
  far.point_lps = far.point_lps - 40.0 * far.normal_lps;  // 40 mm inside
  EXPECT_THROW(search_path(*lps_->fields, far, kOffset, {}), InputError);
  SearchTarget no_normal = ninth_space();
  no_normal.normal_lps = {};
  EXPECT_THROW(search_path(*lps_->fields, no_normal, kOffset, {}), InputError);
  for (auto change :
       {+[](SearchSpec& s) { s.misses_mm.clear(); }, +[](SearchSpec& s) { s.speed_mm_s = 0.0; },
        +[](SearchSpec& s) { s.start_mm = 500.0; }, +[](SearchSpec& s) { s.hold_s = -1.0; },
        +[](SearchSpec& s) { s.misses_mm = {NAN}; }}) {
    SearchSpec spec;
    change(spec);
    EXPECT_THROW(validate(spec), UsageError);
  }
}

}  // namespace
}  // namespace palp
