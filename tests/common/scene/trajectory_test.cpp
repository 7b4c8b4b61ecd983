// Trajectory CSV: strict parsing with line-numbered errors, exact round trips; the force CSV's
// columns, number format, contact summary and writer.
#include "scene/trajectory.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <random>
#include <string>

#include "base/errors.hpp"
#include "support/io_test_util.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using palp::testing::TempDir;
using palp::testing::write_text;

const std::string kHeader = "t,px,py,pz,qw,qx,qy,qz\n";

Trajectory parse(const std::string& text) {
  return parse_trajectory_csv(text, "traj.csv");
}

TEST(TrajectoryCsv, ParsesRowsAndNormalisesQuaternions) {
  const Trajectory t = parse(kHeader + "0,1,2,3,1,0,0,0\n0.001,1.5,-2,3e1,0.9999,0,0,0\n");
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].t, 0.0);
  EXPECT_EQ(t[0].pose.position, (Vec3d{1, 2, 3}));
  EXPECT_EQ(t[1].pose.position, (Vec3d{1.5, -2, 30}));
  EXPECT_DOUBLE_EQ(t[1].pose.orientation.w, 1.0);
  // CRLF line ends and no final newline are fine.
  EXPECT_EQ(parse("t,px,py,pz,qw,qx,qy,qz\r\n0,0,0,0,0,1,0,0").size(), 1u);
}

TEST(TrajectoryCsv, RoundTripIsBitExact) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-500.0, 500.0);
  Trajectory t;
  for (int i = 0; i < 500; ++i) {
    const Quat q = normalized(Quat{u(rng), u(rng), u(rng), u(rng)});
    t.push_back({i * 0.001 + u(rng) * 1e-9, Pose{{u(rng), u(rng), u(rng) * 1e-7}, q}});
  }
  const std::string text = format_trajectory_csv(t);
  EXPECT_EQ(text.rfind(kHeader, 0), 0u);
  const Trajectory back = parse(text);
  ASSERT_EQ(back.size(), t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    EXPECT_EQ(back[i].t, t[i].t);
    EXPECT_EQ(back[i].pose.position, t[i].pose.position);
    // Normalising an already normalised quaternion may move the last bit; no more.
    EXPECT_NEAR(back[i].pose.orientation.w, t[i].pose.orientation.w, 1e-15);
    EXPECT_NEAR(back[i].pose.orientation.z, t[i].pose.orientation.z, 1e-15);
  }
}

TEST(TrajectoryCsv, ErrorsNameTheLine) {
  EXPECT_PALP_ERROR(parse(""), InputError, "empty file");
  EXPECT_PALP_ERROR(parse(kHeader), InputError, "no trajectory rows");
  EXPECT_PALP_ERROR(parse("t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n"), InputError,
                    "traj.csv:1: expected the header");
  EXPECT_PALP_ERROR(parse(kHeader + "0,0,0,0,1,0,0,0\n0.1,0,0,0,1,0,0\n"), InputError,
                    "traj.csv:3: expected 8 values");
  EXPECT_PALP_ERROR(parse(kHeader + "0,0,0,0,1,0,0,0,9\n"), InputError, "got 9");
  EXPECT_PALP_ERROR(parse(kHeader + "0,0,abc,0,1,0,0,0\n"), InputError,
                    "traj.csv:2: column py: 'abc' is not a number");
  EXPECT_PALP_ERROR(parse(kHeader + "0,0,0,0,1,0,0,0\n1,0,0,,1,0,0,0\n"), InputError,
                    "traj.csv:3: column pz");
  EXPECT_PALP_ERROR(parse(kHeader + "0,0,0, 1,1,0,0,0\n"), InputError, "column pz");
  EXPECT_PALP_ERROR(parse(kHeader + "0,0,0,1.5x,1,0,0,0\n"), InputError, "not a number");
  EXPECT_PALP_ERROR(parse(kHeader + "0,nan,0,0,1,0,0,0\n"), InputError,
                    "traj.csv:2: column px: 'nan' is not finite");
  EXPECT_PALP_ERROR(parse(kHeader + "0,0,0,0,inf,0,0,0\n"), InputError, "not finite");
  EXPECT_PALP_ERROR(parse(kHeader + "0,0,0,0,1e400,0,0,0\n"), InputError, "column qw");
  EXPECT_PALP_ERROR(parse(kHeader + "0,0,0,0,0.5,0,0,0\n"), InputError,
                    "traj.csv:2: quaternion (qw,qx,qy,qz) has norm 0.5");
  EXPECT_PALP_ERROR(parse(kHeader + "0,0,0,0,0,0,0,0\n"), InputError, "has norm 0");
  EXPECT_PALP_ERROR(parse(kHeader + "0,0,0,0,1,0,0,0\n0,0,0,0,1,0,0,0\n"), InputError,
                    "traj.csv:3: t must increase");
  EXPECT_PALP_ERROR(parse(kHeader + "0,0,0,0,1,0,0,0\n\n1,0,0,0,1,0,0,0\n"), InputError,
                    "traj.csv:3: empty line");
}

TEST(TrajectoryCsv, Files) {
  TempDir dir;
  EXPECT_PALP_ERROR(read_trajectory_csv(dir.file("none.csv")), InputError, "no such");
  const Trajectory t = parse(kHeader + "0,1,2,3,1,0,0,0\n");
  write_trajectory_csv(dir.file("t.csv"), t);
  EXPECT_FALSE(fs::exists(dir.file("t.csv.partial")));
  EXPECT_EQ(read_trajectory_csv(dir.file("t.csv")).size(), 1u);
  write_text(dir.file("bad.csv"), kHeader + "0,1,2\n");
  EXPECT_PALP_ERROR(read_trajectory_csv(dir.file("bad.csv")), InputError, "bad.csv:2:");
}

TEST(ForceCsv, HeaderStartsWithTheSpecColumns) {
  EXPECT_EQ(std::string(kForceHeader).rfind("t,fx,fy,fz,tx,ty,tz,n_contact,ux,uy,uz,", 0), 0u);
}

TEST(ForceCsv, NumbersAreShortestRoundTrip) {
  std::string out;
  append_number(out, -0.0);
  out += ' ';
  append_number(out, 0.1);
  out += ' ';
  append_number(out, 1.201232);
  out += ' ';
  append_number(out, 1e-300);
  EXPECT_EQ(out, "0 0.1 1.201232 1e-300");
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1e6, 1e6);
  for (int i = 0; i < 1000; ++i) {
    const double v = u(rng) * std::pow(10.0, static_cast<double>(i % 40 - 20));
    std::string text;
    append_number(text, v);
    EXPECT_EQ(std::stod(text), v) << text;
  }
}

TEST(ForceCsv, RowLayout) {
  ForceRecord r;
  r.t = 0.5;
  r.force = {1, -2, 0.25};
  r.torque = {0, 0, -1.5};
  r.n_contact = 7;
  r.u = {0.1, 0, 0};
  r.f_normal = 2;
  r.f_lateral = 0.5;
  r.depth = 4;
  r.status = 2;
  r.safety = 3;
  std::string row;
  append_force_csv_row(row, r);
  EXPECT_EQ(row, "0.5,1,-2,0.25,0,0,-1.5,7,0.1,0,0,2,0.5,4,2,3\n");
  int header_columns = 1, row_columns = 1;
  for (char c : std::string(kForceHeader)) header_columns += c == ',';
  for (char c : row) row_columns += c == ',';
  EXPECT_EQ(header_columns, row_columns);
}

TEST(ForceCsv, RecordSummarisesTheContacts) {
  // Two points in contact on a skin with outward normal +z, one out of contact.
  State st;
  st.x = {{0, 0, -2}, {1, 0, -4}, {5, 5, 5}};
  st.s = {{0, 0, 0}, {1, 0, 0}, {5, 5, 5}};
  st.p = st.s;
  st.f_friction = {{0.3, 0.4, 0.0}, {0.0, 0.0, 0.0}, {0, 0, 0}};
  st.f = {{0.3, 0.4, 1.0}, {0.0, 0.0, 3.0}, {0, 0, 0}};
  st.depth = {2.0, 4.0, 0.0};
  st.in_contact = {1, 1, 0};
  st.n_contact = 2;
  st.f_device = {0.15, 0.2, 2.0};
  st.status = kTickOutsideGrid;
  const ForceRecord r = force_record(1.25, st);
  EXPECT_EQ(r.t, 1.25);
  EXPECT_EQ(r.force, st.f_device);
  EXPECT_EQ(r.n_contact, 2);
  EXPECT_DOUBLE_EQ(r.f_normal, 2.0);    // mean of 1 and 3
  EXPECT_DOUBLE_EQ(r.f_lateral, 0.25);  // mean of 0.5 and 0
  EXPECT_DOUBLE_EQ(r.depth, 3.0);
  EXPECT_EQ(r.status, static_cast<std::uint32_t>(kTickOutsideGrid));
  EXPECT_EQ(r.safety, 0u);
  State none = st;
  none.in_contact = {0, 0, 0};
  none.n_contact = 0;
  EXPECT_EQ(force_record(0, none).f_normal, 0.0);
}

TEST(ForceCsv, WriterRenamesOnFinishAndCleansUpOtherwise) {
  TempDir dir;
  ForceRecord r;
  {
    ForceCsvWriter writer(dir.file("f.csv"));
    for (int i = 0; i < 3; ++i) {
      r.t = i;
      writer.write(r);
    }
    EXPECT_FALSE(fs::exists(dir.file("f.csv")));
    writer.finish();
  }
  const auto bytes = palp::testing::read_bytes(dir.file("f.csv"));
  const std::string text(bytes.begin(), bytes.end());
  EXPECT_EQ(text.rfind(std::string(kForceHeader) + "\n0,", 0), 0u);
  int lines = 0;
  for (char c : text) lines += c == '\n';
  EXPECT_EQ(lines, 4);
  { ForceCsvWriter abandoned(dir.file("g.csv")); }
  EXPECT_FALSE(fs::exists(dir.file("g.csv")));
  EXPECT_FALSE(fs::exists(dir.file("g.csv.partial")));
  EXPECT_THROW(ForceCsvWriter(dir.file("no/such/dir/f.csv")), Error);
}

}  // namespace
}  // namespace palp
