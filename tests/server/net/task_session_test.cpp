// The live task session without a server: samples at the session's rate into its bounded buffer,
// the mark button's rising edge, marks beyond the bound refused and counted, trials kept and
// reported, the trainee's and the instructor's views, the scene <-> LPS placement.
#include "net/task_session.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "base/patient_frame.hpp"
#include "net/task_messages.hpp"

namespace palp::net {
namespace {

// A space 9/10 on the right at LPS (-30, 0, 0) between ribs at z = +-12, on a grid placed with
// its origin at -49.5 (as the sphere phantom).
anatomy::Landmarks fixture() {
  anatomy::Landmarks l;
  anatomy::IntercostalSpace s;
  s.upper_rib = 9;
  s.skin_point = Vec3d{-30, 0, 0};
  s.normal = Vec3d{-1, 0, 0};
  s.confidence = 1;
  l.intercostal_spaces.push_back(s);
  for (const auto& [number, z] : {std::pair{9, 12.0}, std::pair{10, -12.0}}) {
    anatomy::Rib r;
    r.number = number;
    r.confidence = 1;
    for (double y = -10; y <= 10; y += 5) r.points.push_back({-28.0, y, z});
    l.ribs.push_back(r);
  }
  return l;
}

Grid placement() {
  Grid g;
  g.world.origin = {-49.5, -49.5, -49.5};
  return g;
}

// A snapshot at tick `seq` (1 kHz), the pad's one contact on the skin at LPS `lps`.
rt::Snapshot at(std::uint64_t seq, const Vec3d& lps, std::uint32_t buttons = 0) {
  rt::Snapshot s;
  s.contacts.resize(1);
  s.tick.seq = seq;
  s.tick.t_ns = 1'000'000'000 + static_cast<std::int64_t>(seq) * 1'000'000;
  s.tick.pose.position = scene_of_world(placement(), lps);
  s.tick.force = {2.0, 0.0, 0.0};
  s.contact_count = 1;
  s.contacts[0].in_contact = 1;
  s.contacts[0].p = scene_of_world(placement(), lps);
  s.buttons = buttons;
  return s;
}

TaskSetup setup(std::size_t max_samples = 1000, std::size_t max_marks = 4) {
  TaskSetup t;
  t.landmarks = fixture();
  t.grid = placement();
  t.max_samples = max_samples;
  t.max_marks = max_marks;
  return t;
}

training::TaskSpec ptcd9() {
  return {};  // ptcd, right, 9/10
}

TEST(TaskSession, SamplesAtItsRateIntoABoundedBuffer) {
  TaskSession task(setup(50));
  ASSERT_EQ(task.start(ptcd9()), "");
  for (std::uint64_t i = 0; i < 400; ++i) task.offer(at(i, {-30, 0, 0}));  // 0.4 s at 1 kHz
  EXPECT_EQ(task.samples_in_trial(), 40u);                                 // 100 Hz
  for (std::uint64_t i = 400; i < 1000; ++i) task.offer(at(i, {-30, 0, 0}));
  EXPECT_EQ(task.samples_in_trial(), 50u);
  EXPECT_EQ(task.view().samples_dropped, 50u);  // counted, never grown
}

TEST(TaskSession, TheButtonsRisingEdgeMarksAndScores) {
  TaskSession task(setup());
  ASSERT_EQ(task.start(ptcd9()), "");
  task.offer(at(0, {-30, 0, 20}));
  task.offer(at(100, {-30, 0, 1}, rt::kMarkButton));  // pressed
  task.offer(at(101, {-30, 0, 1}, rt::kMarkButton));  // held: no second mark
  task.offer(at(102, {-30, 0, 1}, 0x4));              // another button: no mark
  EXPECT_EQ(task.view().marks, 1u);
  ASSERT_TRUE(task.view().last_mark);
  EXPECT_NEAR(task.view().last_mark->distance_mm, 1.0, 1e-6);
  EXPECT_TRUE(task.view().last_mark->in_target);
  EXPECT_NEAR(task.view().last_mark->mark.t, 0.1, 1e-9);
  // the trainee's controller sees neither the score nor the target while the task runs
  v1::TaskStatus trainee, instructor;
  fill_task_status(task.view(), true, &trainee);
  fill_task_status(task.view(), false, &instructor);
  EXPECT_FALSE(trainee.show_landmarks());
  EXPECT_FALSE(trainee.has_last_mark());
  EXPECT_FALSE(trainee.has_target());
  EXPECT_TRUE(instructor.show_landmarks());
  ASSERT_TRUE(instructor.has_last_mark());
  EXPECT_EQ(instructor.last_mark().where(), "target");
  EXPECT_EQ(instructor.trial(), 1u);
}

TEST(TaskSession, MarksBeyondTheBoundAreRefusedAndCounted) {
  TaskSession task(setup(1000, 2));
  EXPECT_NE(task.mark(), "");  // no task
  ASSERT_EQ(task.start(ptcd9()), "");
  task.offer(at(0, {-30, 0, 14}));  // on rib 9
  EXPECT_EQ(task.mark(), "");
  EXPECT_EQ(task.mark(), "");
  EXPECT_NE(task.mark(), "");
  EXPECT_EQ(task.view().marks, 2u);
  EXPECT_EQ(task.view().marks_dropped, 1u);
  ASSERT_TRUE(task.view().last_mark);
  EXPECT_FALSE(task.view().last_mark->in_target);
}

TEST(TaskSession, TrialsAreKeptAndTheReportWrittenAtTheEnd) {
  TaskSetup s = setup();
  int reports = 0;
  std::size_t trials = 0;
  std::vector<std::uint64_t> marked;
  s.write_report = [&](const TaskSessionRecord& r) {
    ++reports;
    trials = r.trials.size();
    return std::string("/reports/x.html");
  };
  s.on_mark = [&](std::uint64_t seq, std::int64_t) { marked.push_back(seq); };
  TaskSession task(std::move(s));
  EXPECT_NE(task.start({training::TaskKind::ptcd, anatomy::Side::left, 9, "L3/L4"}), "");
  ASSERT_EQ(task.start(ptcd9()), "");
  EXPECT_NE(task.start(ptcd9()), "");  // one at a time
  task.offer(at(0, {-30, 0, 0}));
  EXPECT_EQ(task.mark(), "");
  EXPECT_EQ(task.next_trial(), "");
  EXPECT_EQ(task.view().trial, 2);
  EXPECT_EQ(task.view().marks, 0u);
  task.replay_marks({5});
  task.offer(at(5, {-30, 0, 3}));  // a replayed mark
  EXPECT_EQ(task.view().marks, 1u);
  task.finish();
  EXPECT_FALSE(task.view().running);
  EXPECT_EQ(reports, 1);
  EXPECT_EQ(trials, 2u);
  EXPECT_EQ(task.view().report, "/reports/x.html");
  EXPECT_EQ(marked, (std::vector<std::uint64_t>{0, 5}));
  EXPECT_NE(task.stop(), "");  // nothing runs
  v1::TaskStatus trainee;
  fill_task_status(task.view(), true, &trainee);  // stopped: the trainee may see it all
  EXPECT_TRUE(trainee.show_landmarks());
}

TEST(TaskSession, WithoutLandmarksEveryStartIsRefused) {
  TaskSetup s = setup();
  s.landmarks.reset();
  TaskSession task(std::move(s));
  EXPECT_NE(task.start(ptcd9()).find("--landmarks"), std::string::npos);
}

}  // namespace
}  // namespace palp::net
