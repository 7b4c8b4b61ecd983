// The landmarks' JSON: a full set round-trips to the writer's precision, absent points and
// numbers stay null, and malformed or oversized input is refused with the place named.
#include "anatomy/landmarks.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "base/errors.hpp"
#include "support/io_test_util.hpp"

namespace palp::anatomy {
namespace {

using palp::testing::TempDir;
using palp::testing::write_text;

Landmarks sample() {
  Landmarks l;
  l.scene = "phantom:trunk";
  l.notes = {"no femoral artery in the scan"};
  l.ribs.push_back({Side::right, 9, {{-20.0, 60.0, 100.0}, {-90.0, 10.0, 80.0}}, 0.9, ""});
  l.ribs.push_back({Side::left, std::nullopt, {{20.0, 60.0, 70.0}}, 0.2, "no T12 to count from"});
  l.intercostal_spaces.push_back(
      {Side::right, 9, Vec3d{-150.004, -20.0, 61.236}, Vec3d{-1.0, 0.0, 0.0}, 0.8, ""});
  l.intercostal_spaces.push_back(
      {Side::right, 12, std::nullopt, std::nullopt, 0.0, "rib 12 ends before the line"});
  l.vertebrae.push_back({std::string("L4"), {0.0, 40.0, -120.0}, Vec3d{0.0, 95.0, -130.0}, 1.0, ""});
  l.vertebrae.push_back({std::nullopt, {0.0, 40.0, -90.0}, std::nullopt, 0.1, "cut by the scan"});
  l.iliac_crests.push_back({Side::left, Vec3d{110.0, 40.0, -125.0}, 0.95, ""});
  l.tuffier_line = {-125.0, std::string("L4"), 0.9, ""};
  l.lumbar_interspaces.push_back({"L3/L4", Vec3d{0.0, 110.0, -110.0}, Vec3d{0.0, 1.0, 0.0}, 0.9, ""});
  l.femoral_pulse_points.push_back(
      {Side::right, Vec3d{-80.0, -60.0, -260.0}, Vec3d{0.0, -1.0, 0.0}, "mid-inguinal", 0.5, ""});
  return l;
}

TEST(LandmarksJson, RoundTripsToTheWritersPrecision) {
  const Landmarks l = landmarks_from_json(landmarks_to_json(sample()), "x.json");
  ASSERT_EQ(l.ribs.size(), 2u);
  EXPECT_EQ(l.ribs[0].number, 9);
  EXPECT_EQ(l.ribs[0].points.size(), 2u);
  EXPECT_FALSE(l.ribs[1].number.has_value());
  EXPECT_EQ(l.ribs[1].reason, "no T12 to count from");
  ASSERT_EQ(l.intercostal_spaces.size(), 2u);
  // Written to 0.01 mm: -150.004 -> -150.0, 61.236 -> 61.24.
  EXPECT_NEAR(l.intercostal_spaces[0].skin_point->x, -150.0, 1e-9);
  EXPECT_NEAR(l.intercostal_spaces[0].skin_point->z, 61.24, 1e-9);
  EXPECT_FALSE(l.intercostal_spaces[1].skin_point.has_value());
  EXPECT_FALSE(l.intercostal_spaces[1].normal.has_value());
  EXPECT_EQ(l.vertebrae[0].name, std::optional<std::string>("L4"));
  EXPECT_FALSE(l.vertebrae[1].name.has_value());
  EXPECT_FALSE(l.vertebrae[1].spinous_tip.has_value());
  EXPECT_EQ(l.tuffier_line.vertebral_level, std::optional<std::string>("L4"));
  EXPECT_EQ(l.femoral_pulse_points[0].source, "mid-inguinal");
  EXPECT_EQ(l.scene, "phantom:trunk");
  ASSERT_EQ(l.notes.size(), 1u);
  // A second trip changes nothing: the text is a fixed point.
  EXPECT_EQ(landmarks_to_json(l), landmarks_to_json(landmarks_from_json(landmarks_to_json(l), "y")));
}

TEST(LandmarksJson, AbsentIsNullInTheText) {
  const std::string text = landmarks_to_json(sample());
  EXPECT_NE(text.find("\"number\": null"), std::string::npos);
  EXPECT_NE(text.find("\"skin_point\": null"), std::string::npos);
  EXPECT_NE(text.find("\"frame\": \"LPS\""), std::string::npos);
}

void expect_refused(const std::string& text, const std::string& fragment) {
  try {
    landmarks_from_json(text, "bad.json");
    FAIL() << "accepted: " << text;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
  }
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

TEST(LandmarksJson, RefusesMalformedInput) {
  const std::string good = landmarks_to_json(sample());
  expect_refused("[1,2]", "not a JSON object");
  expect_refused("{", "not a JSON object");
  expect_refused(replaced(good, "\"side\": \"left\"", "\"side\": \"up\""), "side");
  expect_refused(replaced(good, "\"confidence\": 0.9", "\"confidence\": 1.5"), "outside [0, 1]");
  expect_refused(replaced(good, "\"number\": 9", "\"number\": \"nine\""), "ribs[0].number");
  expect_refused(replaced(good, "\"tuffier_line\"", "\"tuffier\""), "tuffier_line");
  expect_refused(replaced(good, "\"top\": [", "\"top\": [1, "), "iliac_crests[0]");
}

TEST(LandmarksJson, RefusesMoreEntriesThanTheBound) {
  Landmarks l = sample();
  l.ribs.assign(kMaxLandmarkItems + 1, l.ribs[0]);
  expect_refused(landmarks_to_json(l), "more than 256 entries");
  l = sample();
  l.ribs[0].points.assign(kMaxRibPoints + 1, Vec3d{});
  expect_refused(landmarks_to_json(l), "more than 512 points");
}

TEST(LandmarksFile, WritesReadsAndBoundsTheSize) {
  TempDir dir;
  const std::string path = (dir.path() / "landmarks.json").string();
  write_landmarks(path, sample());
  EXPECT_EQ(read_landmarks(path).vertebrae.size(), 2u);
  EXPECT_FALSE(std::filesystem::exists(path + ".partial"));
  const std::string big = (dir.path() / "big.json").string();
  {
    std::ofstream out(big);
    out << std::string(kMaxLandmarksFileBytes + 1, ' ');
  }
  EXPECT_THROW(read_landmarks(big), InputError);
  EXPECT_THROW(read_landmarks((dir.path() / "missing.json").string()), InputError);
}

TEST(LandmarksLookup, FindsBySideNumberAndName) {
  const Landmarks l = sample();
  EXPECT_NE(find_intercostal_space(l, Side::right, 9), nullptr);
  EXPECT_EQ(find_intercostal_space(l, Side::left, 9), nullptr);
  EXPECT_NE(find_lumbar_interspace(l, "L3/L4"), nullptr);
  EXPECT_EQ(find_lumbar_interspace(l, "L4/L5"), nullptr);
  EXPECT_NE(find_femoral_pulse_point(l, Side::right), nullptr);
  EXPECT_EQ(find_femoral_pulse_point(l, Side::left), nullptr);
  EXPECT_NE(find_rib(l, Side::right, 9), nullptr);
  EXPECT_EQ(find_rib(l, Side::left, 9), nullptr);
  EXPECT_NE(find_vertebra(l, "L4"), nullptr);
  EXPECT_EQ(find_vertebra(l, "L5"), nullptr);
  EXPECT_EQ(parse_side("l"), Side::left);
  EXPECT_FALSE(parse_side("middle").has_value());
}

}  // namespace
}  // namespace palp::anatomy
