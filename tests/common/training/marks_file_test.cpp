// The marks file of palp task and the split of a run into trials: the documented columns, line
// ends and bounds, errors naming file and line, and each trial's window rebased to its first row.
#include "training/marks_file.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "base/errors.hpp"

namespace {

using namespace palp::training;

std::string error_of(const std::string& text) {
  try {
    parse_marks_csv(text, "m.csv");
  } catch (const palp::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(MarksFile, ReadsTimesTrialsAndIgnoresOtherColumns) {
  const auto plain = parse_marks_csv("t\r\n0.5\r\n\r\n1.25\r\n", "m.csv");
  ASSERT_EQ(plain.size(), 2u);
  EXPECT_EQ(plain[1].t, 1.25);
  EXPECT_EQ(plain[1].trial, 1);
  const auto trials = parse_marks_csv("note, trial ,t\nfirst,1,0.5\nsecond,2,0.7\n,2,0.9", "m");
  ASSERT_EQ(trials.size(), 3u);
  EXPECT_EQ(trials[2].trial, 2);
  EXPECT_EQ(trials[2].t, 0.9);
  EXPECT_TRUE(parse_marks_csv("t\n", "m").empty());
}

// What palp traj search writes, palp task reads back exactly: the documented header, and times
// that are not short decimals (0.1 + 0.2, a third) come back bit for bit.
TEST(MarksFile, WrittenMarksReadBackExactly) {
  const std::vector<MarkRow> marks = {{1, 0.1 + 0.2}, {2, 1.0 / 3.0}, {2, 7.5}};
  const std::string text = format_marks_csv(marks);
  EXPECT_EQ(text.rfind("trial,t\n", 0), 0u) << text;
  const std::vector<MarkRow> back = parse_marks_csv(text, "m.csv");
  ASSERT_EQ(back.size(), marks.size());
  for (std::size_t k = 0; k < marks.size(); ++k) {
    EXPECT_EQ(back[k].trial, marks[k].trial);
    EXPECT_EQ(back[k].t, marks[k].t);
  }
}

TEST(MarksFile, RefusesWhatItCannotTrust) {
  EXPECT_NE(error_of("").find("empty"), std::string::npos);
  EXPECT_NE(error_of("time\n1\n").find("m.csv:1: the header has no column t"), std::string::npos);
  EXPECT_NE(error_of("t\n1\nx\n").find("m.csv:3: t is not a number"), std::string::npos);
  EXPECT_NE(error_of("t\nnan\n").find("not a number"), std::string::npos);
  EXPECT_NE(error_of("t\n2\n1\n").find("m.csv:3: marks go back in time"), std::string::npos);
  EXPECT_NE(error_of("trial,t\n1,1\n3,2\n").find("without gaps"), std::string::npos);
  EXPECT_NE(error_of("trial,t\n2,1\n").find("without gaps"), std::string::npos);
  EXPECT_NE(error_of("trial,t\n0,1\n").find("from 1"), std::string::npos);
  EXPECT_NE(error_of("trial,t\n1\n").find("1 cells, the header has 2"), std::string::npos);
  std::string many = "t\n";
  for (std::size_t i = 0; i <= kMaxTrialMarks; ++i) many += "1\n";
  EXPECT_NE(error_of(many).find("more than 1000 marks"), std::string::npos);
  EXPECT_THROW(read_marks_csv("/nonexistent/marks.csv"), palp::InputError);
}

std::vector<TrialSample> run_of(int rows) {
  std::vector<TrialSample> samples(static_cast<std::size_t>(rows));
  for (int i = 0; i < rows; ++i) {
    samples[i].t = 10.0 + 0.5 * i;
    samples[i].skin_point = {static_cast<double>(i), 0.0, 0.0};
  }
  return samples;
}

TEST(MarksFile, SplitsTheRunAtEachTrialsLastMark) {
  // Rows at t = 10, 10.5, ..., 14.5; trial 1 marks at 11 and 11.7 (rows 2 and 3), trial 2 at 13.
  const std::vector<Trial> trials = split_trials(run_of(10), {{1, 11.0}, {1, 11.7}, {2, 13.0}});
  ASSERT_EQ(trials.size(), 2u);
  EXPECT_EQ(trials[0].number, 1);
  ASSERT_EQ(trials[0].samples.size(), 4u) << "rows 0..3: up to the last mark's row";
  EXPECT_EQ(trials[0].samples.front().t, 0.0);
  ASSERT_EQ(trials[0].marks.size(), 2u);
  EXPECT_NEAR(trials[0].marks[1].t, 1.7, 1e-12);
  EXPECT_EQ(trials[0].marks[1].point.x, 3.0) << "the row at or before the mark";
  ASSERT_EQ(trials[1].samples.size(), 6u) << "rows 4..9: to the run's end";
  EXPECT_EQ(trials[1].samples.front().t, 0.0);
  EXPECT_NEAR(trials[1].marks[0].t, 1.0, 1e-12) << "13 s, 1 s after the trial's first row";
  EXPECT_EQ(trials[1].marks[0].point.x, 6.0);
  EXPECT_EQ(split_trials(run_of(3), {}).size(), 1u);
  EXPECT_THROW(split_trials(run_of(3), {{1, 20.0}}), palp::InputError);
  EXPECT_THROW(split_trials(run_of(3), {{1, 9.0}}), palp::InputError);
  EXPECT_THROW(split_trials(run_of(3), {{1, 11.0}, {2, 11.0}}), palp::InputError)
      << "trial 2 would have no rows";
  EXPECT_THROW(split_trials({}, {}), palp::InputError);
}

}  // namespace
