// Training tasks scored by a scripted trainee on tiny inline landmarks: marks in the asked space
// score "target" at the hand-computed distance; marks on a rib, in the space above, on a spinous
// process or off the midline score what they are; the metrics of a straight path at constant
// speed are its length and duration exactly.
#include "training/task.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "base/errors.hpp"
#include "support/training_landmarks.hpp"

namespace {

using palp::Vec3d;
using palp::anatomy::Landmarks;
using palp::anatomy::Side;
using namespace palp::training;
using palp::testing::rib_z;
using palp::testing::torso_landmarks;

TaskSpec ptcd(int space, Side side = Side::right) {
  TaskSpec spec;
  spec.kind = TaskKind::ptcd;
  spec.space = space;
  spec.side = side;
  return spec;
}

TaskSpec lumbar(const char* interspace) {
  TaskSpec spec;
  spec.kind = TaskKind::lumbar;
  spec.interspace = interspace;
  return spec;
}

Placement where(const TaskSpec& spec, const Vec3d& point) {
  const Landmarks lm = torso_landmarks();
  return classify(resolve_target(spec, lm), lm, point);
}

TEST(Task, NamesParseAndDescribe) {
  EXPECT_EQ(parse_task_kind("lumbar"), TaskKind::lumbar);
  EXPECT_FALSE(parse_task_kind("ptcd "));
  EXPECT_EQ(describe(TaskSpec{}), "ptcd right 9/10");
  EXPECT_EQ(describe(lumbar("L4/L5")), "lumbar L4/L5");
  EXPECT_THROW(validate(ptcd(12)), palp::UsageError);
  EXPECT_THROW(validate(ptcd(0)), palp::UsageError);
  EXPECT_THROW(validate(lumbar("L3/L5")), palp::UsageError);
  EXPECT_THROW(validate(lumbar("T12/L1")), palp::UsageError);
  EXPECT_NO_THROW(validate(lumbar("L5/S1")));
}

TEST(Task, ResolvesTheTargetsFromTheLandmarks) {
  const Landmarks lm = torso_landmarks();
  const TaskTarget t = resolve_target(TaskSpec{}, lm);
  EXPECT_EQ(t.point, (Vec3d{-170.0, 0.0, 62.5}));
  EXPECT_EQ(t.normal, (Vec3d{-1.0, 0.0, 0.0}));
  const TaskView view = task_view(t);
  EXPECT_EQ(view.up, (Vec3d{0.0, 0.0, 1.0}));
  EXPECT_NEAR(view.across.y, -1.0, 1e-12) << "the viewer's right is the patient's anterior";
  TaskSpec femoral;
  femoral.kind = TaskKind::femoral;
  femoral.side = Side::left;
  const TaskTarget f = resolve_target(femoral, lm);
  EXPECT_EQ(f.radius_mm, kFemoralPulseRadiusMm);
  EXPECT_TRUE(f.pulse_felt);
  Landmarks no_space = lm;
  no_space.intercostal_spaces.clear();
  EXPECT_THROW(resolve_target(TaskSpec{}, no_space), palp::InputError);
  Landmarks unplaced = lm;
  unplaced.lumbar_interspaces[2].skin_point.reset();
  unplaced.lumbar_interspaces[2].reason = "cut by the scan";
  try {
    resolve_target(lumbar("L3/L4"), unplaced);
    FAIL();
  } catch (const palp::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cut by the scan"), std::string::npos) << e.what();
  }
}

TEST(Task, PtcdMarksScoreTheSpaceTheRibOrTheSpaceAbove) {
  // At y = 0: rib 9 at z = 75, rib 10 at 50, the 9/10 space's skin point at z = 62.5.
  EXPECT_EQ(where(TaskSpec{}, {-170.0, 0.0, 65.5}).where, "target");
  EXPECT_TRUE(where(TaskSpec{}, {-170.0, 0.0, 65.5}).in_target);
  EXPECT_EQ(where(TaskSpec{}, {-170.0, 0.0, 77.0}).where, "rib 9");
  EXPECT_EQ(where(TaskSpec{}, {-170.0, 0.0, 68.5}).where, "target") << "6.5 mm below rib 9";
  EXPECT_EQ(where(TaskSpec{}, {-170.0, 0.0, 87.5}).where, "space 8/9");
  EXPECT_EQ(where(TaskSpec{}, {-170.0, 0.0, 45.0}).where, "rib 10");
  EXPECT_EQ(where(TaskSpec{}, {-170.0, 0.0, 200.0}).where, "above rib 5");
  // The slope: 50 mm anterior (y = -50) rib 9 is 10 mm lower, at z = 65.
  EXPECT_EQ(where(TaskSpec{}, {-170.0, -50.0, 65.0}).where, "rib 9");
  EXPECT_EQ(where(TaskSpec{}, {-170.0, -50.0, 52.5}).where, "target");
  EXPECT_EQ(where(TaskSpec{}, {170.0, 0.0, 62.5}).where, "left side, space 9/10");
  EXPECT_FALSE(where(TaskSpec{}, {170.0, 0.0, 62.5}).in_target);
  EXPECT_EQ(where(ptcd(9, Side::left), {170.0, 0.0, 62.5}).where, "target");
}

TEST(Task, LumbarMarksScoreInterspacesTipsAndTheMidline) {
  // Tips: L3 at z = 95, L4 at 60, L5 at 25; the L3/L4 skin point at z = 77.5.
  EXPECT_EQ(where(lumbar("L3/L4"), {0.0, 90.0, 77.5}).where, "target");
  EXPECT_EQ(where(lumbar("L3/L4"), {0.0, 90.0, 100.0}).where, "spinous process L3");
  EXPECT_EQ(where(lumbar("L3/L4"), {0.0, 90.0, 112.5}).where, "L2/L3");
  EXPECT_EQ(where(lumbar("L3/L4"), {-15.0, 90.0, 77.5}).where, "L3/L4, 15 mm off the midline");
  EXPECT_TRUE(where(lumbar("L3/L4"), {8.0, 90.0, 77.5}).in_target);
  EXPECT_EQ(where(lumbar("L3/L4"), {0.0, 90.0, 200.0}).where, "above L1");
  // Below L5: the sacrum's level mirrored from the L5/S1 point (z = 7.5) about L5's tip: -10.
  EXPECT_EQ(where(lumbar("L5/S1"), {0.0, 90.0, 5.0}).where, "target");
  EXPECT_EQ(where(lumbar("L3/L4"), {0.0, 90.0, 5.0}).where, "L5/S1");
  EXPECT_EQ(where(lumbar("L3/L4"), {0.0, 90.0, -30.0}).where, "below S");
}

TEST(Task, FemoralMarksScoreAgainstThePulseRadius) {
  TaskSpec spec;
  spec.kind = TaskKind::femoral;
  EXPECT_EQ(where(spec, {-80.0, -100.0, -139.0}).where, "target");
  EXPECT_EQ(where(spec, {-80.0, -100.0, -130.0}).where, "off the pulse");
  EXPECT_EQ(where(spec, {80.0, -100.0, -150.0}).where, "the left pulse");
  Landmarks bones = torso_landmarks();
  bones.femoral_pulse_points[0].source = "mid-inguinal";
  const TaskTarget t = resolve_target(spec, bones);
  EXPECT_FALSE(t.pulse_felt);
  ASSERT_EQ(t.notes.size(), 1u);
  EXPECT_NE(t.notes[0].find("no artery"), std::string::npos);
}

// A straight slide at constant speed in contact from t = 0.1 s to 1 s (20 mm/s along the
// patient's superior), the normal force ramping 0 -> 4.5 N; out of contact before.
std::vector<TrialSample> straight_slide() {
  std::vector<TrialSample> samples;
  for (int i = 0; i <= 1000; ++i) {
    TrialSample s;
    s.t = i * 0.001;
    s.device_point = {-172.0, 0.0, 40.0 + 20.0 * s.t};
    s.skin_point = {-170.0, 0.0, 40.0 + 20.0 * s.t};
    s.in_contact = i >= 100;
    s.normal_force = s.in_contact ? 5.0 * s.t : 0.0;
    samples.push_back(s);
  }
  return samples;
}

TEST(Task, MetricsOfAStraightSlideAtConstantSpeed) {
  const Landmarks lm = torso_landmarks();
  const TaskTarget target = resolve_target(TaskSpec{}, lm);
  const std::vector<TrialSample> samples = straight_slide();
  // Marks at t = 0.9 (z = 58: the space) and, given first, t = 0.5002 (z = 50: on rib 10).
  const std::vector<Mark> marks = {mark_at(samples, 0.9005), mark_at(samples, 0.5002)};
  const TrialScore score = score_trial(target, lm, samples, marks);
  EXPECT_NEAR(score.path_length_mm, 20.0 * 0.9, 1e-9) << "speed x time in contact";
  EXPECT_NEAR(score.time_in_contact_s, 0.9, 1e-9);
  EXPECT_NEAR(score.duration_s, 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(score.peak_force_n, 5.0);
  EXPECT_NEAR(score.mean_force_n, 5.0 * 0.55, 1e-9) << "mean of the ramp over t in [0.1, 1]";
  ASSERT_TRUE(score.time_to_first_mark_s);
  EXPECT_DOUBLE_EQ(*score.time_to_first_mark_s, 0.5002);
  ASSERT_EQ(score.marks.size(), 2u);
  EXPECT_EQ(score.marks[0].where, "rib 10");
  EXPECT_NEAR(score.marks[0].distance_mm, 12.5, 1e-9);
  EXPECT_EQ(score.marks[1].where, "target");
  EXPECT_TRUE(score.marks[1].in_target);
  EXPECT_NEAR(score.marks[1].distance_mm, 4.5, 1e-9) << "z = 58 against the space's 62.5";
}

TEST(Task, RefusesDisorderedNonFiniteAndOversizedTrials) {
  const Landmarks lm = torso_landmarks();
  const TaskTarget target = resolve_target(TaskSpec{}, lm);
  std::vector<TrialSample> samples = straight_slide();
  std::swap(samples[3], samples[4]);
  EXPECT_THROW(score_trial(target, lm, samples, {}), palp::InputError);
  samples = straight_slide();
  samples[7].skin_point.z = NAN;
  EXPECT_THROW(score_trial(target, lm, samples, {}), palp::InputError);
  EXPECT_THROW(score_trial(target, lm, std::vector<TrialSample>(kMaxTrialSamples + 1), {}),
               palp::InputError);
  EXPECT_THROW(score_trial(target, lm, {}, std::vector<Mark>(kMaxTrialMarks + 1)),
               palp::InputError);
  EXPECT_THROW(mark_at({}, 0.0), palp::InputError);
  const TrialScore empty = score_trial(target, lm, {}, {});
  EXPECT_FALSE(empty.time_to_first_mark_s);
  EXPECT_EQ(empty.duration_s, 0.0);
}

}  // namespace
