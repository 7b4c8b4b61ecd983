// The cohort CSV: the header once, one row per trial in the documented columns, text cells that
// cannot break the table or run as a formula, refusal of a foreign table, and concurrent
// appenders that neither lose nor interleave rows.
#include "training/cohort_csv.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>
#include <vector>

#include "base/errors.hpp"
#include "support/training_session.hpp"

namespace {

namespace fs = std::filesystem;
using namespace palp::training;
using palp::testing::ptcd_session;

std::vector<std::string> lines_of(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

fs::path fresh(const char* name) {
  const fs::path path = fs::path(::testing::TempDir()) / name;
  fs::remove(path);
  return path;
}

TEST(CohortCsv, RowsFollowTheHeaderColumns) {
  const std::string rows = cohort_csv_rows(ptcd_session());
  std::istringstream in(rows);
  std::string one, two;
  std::getline(in, one);
  std::getline(in, two);
  EXPECT_EQ(one,
            "session-1,trainee-7,ptcd right 9/10,inline,1,1,target,1,4.500,4.500,0.900,5.000,"
            "2.750,18.000,0.900,1.000");
  EXPECT_EQ(two.substr(0, 45), "session-1,trainee-7,ptcd right 9/10,inline,2,");
  EXPECT_NE(two.find(",rib 9,0,15.500,"), std::string::npos) << two;
  EXPECT_EQ(std::count(one.begin(), one.end(), ','),
            std::count(kCohortCsvHeader, kCohortCsvHeader + std::strlen(kCohortCsvHeader), ','));
}

TEST(CohortCsv, TextCellsAreQuotedAndFormulasNeutralized) {
  palp::training::Session session = ptcd_session("=HYPERLINK(\"x\")");
  session.id = "a,b";
  session.trials.resize(1);
  session.trials[0].score.marks.clear();
  EXPECT_EQ(cohort_csv_rows(session).substr(0, 31), "\"a,b\",\"'=HYPERLINK(\"\"x\"\")\",ptcd");
  EXPECT_NE(cohort_csv_rows(session).find(",1,0,,,,"), std::string::npos)
      << "no mark: empty where, in_target and distances";
}

TEST(CohortCsv, HeaderOnceThenRowsAppended) {
  const fs::path path = fresh("palp_cohort_append.csv");
  append_cohort_csv(path.string(), ptcd_session());
  append_cohort_csv(path.string(), ptcd_session("trainee-8"));
  const std::vector<std::string> lines = lines_of(path);
  ASSERT_EQ(lines.size(), 5u);
  EXPECT_EQ(lines[0], kCohortCsvHeader);
  EXPECT_EQ(lines[3].rfind("session-1,trainee-8,", 0), 0u);
}

TEST(CohortCsv, RefusesAnotherTable) {
  const fs::path path = fresh("palp_cohort_foreign.csv");
  std::ofstream(path) << "t,fx,fy,fz\n0,1,2,3\n";
  EXPECT_THROW(append_cohort_csv(path.string(), ptcd_session()), palp::InputError);
  EXPECT_EQ(lines_of(path).size(), 2u) << "left as it was";
}

TEST(CohortCsv, ConcurrentAppendersKeepEveryRowWhole) {
  const fs::path path = fresh("palp_cohort_concurrent.csv");
  const palp::training::Session session = ptcd_session();
  std::vector<std::thread> writers;
  for (int i = 0; i < 8; ++i)
    writers.emplace_back([&] {
      for (int k = 0; k < 10; ++k) append_cohort_csv(path.string(), session);
    });
  for (auto& w : writers) w.join();
  const std::vector<std::string> lines = lines_of(path);
  ASSERT_EQ(lines.size(), 1u + 8u * 10u * 2u);
  EXPECT_EQ(lines[0], kCohortCsvHeader);
  for (std::size_t i = 1; i < lines.size(); ++i)
    EXPECT_EQ(lines[i].rfind("session-1,trainee-7,ptcd right 9/10,inline,", 0), 0u) << i;
}

}  // namespace
