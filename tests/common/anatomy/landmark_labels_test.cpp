// palp landmarks --labels (issue 40): a TotalSegmentator-style multi-label NIfTI of the trunk
// phantom, built from its truth labels (PhantomTruth::bone_label) with the ids of palp's own
// class map (labels::find_total_class), prepped with it: every vertebra and rib is named from
// its label (confidence 0.95). A second map mislabels L3 as T1 and the right 9th rib as the 3rd:
// the label map wins, and the note, the reason and the confidence say the count disagrees.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "anatomy/landmark_detection.hpp"
#include "anatomy/skeleton_labels.hpp"
#include "anatomy/trunk_truth.hpp"
#include "io/ct_io.hpp"
#include "io/phantom.hpp"
#include "prep/labels/label_classes.hpp"
#include "prep/labels/label_maps.hpp"
#include "prep/prep.hpp"
#include "support/io_test_util.hpp"
#include "support/label_files.hpp"

namespace palp::anatomy {
namespace {

// The TotalSegmentator class of a trunk phantom bone label (phantom_trunk.hpp), by name.
std::string total_class_name(std::uint8_t label) {
  if (label >= 8 && label <= 12) return "vertebrae_T" + std::to_string(label);
  if (label >= 13 && label <= 17) return "vertebrae_L" + std::to_string(label - 12);
  if (label == 18) return "sacrum";
  if (label > 20 && label <= 32) return "rib_right_" + std::to_string(label - 20);
  if (label > 40 && label <= 52) return "rib_left_" + std::to_string(label - 40);
  if (label == 60) return "hip_right";
  if (label == 61) return "hip_left";
  if (label == 62) return "femur_right";
  if (label == 63) return "femur_left";
  return "";  // the coccyx: no class of its own in the total task
}

// Writes the phantom's CT and its label map (`rename`: truth class -> the class written instead).
struct TrunkWithLabels {
  std::string ct, labels;
};
TrunkWithLabels write_trunk(const testing::TempDir& dir,
                            const std::map<std::string, std::string>& rename = {}) {
  PhantomTruth truth;
  const CtVolume ct = make_phantom("trunk", {}, &truth);
  TrunkWithLabels out{dir.file("trunk.nii.gz"), dir.file("trunk_total.nii.gz")};
  write_nifti(out.ct, ct);
  std::map<std::uint8_t, std::uint8_t> id;
  for (int label = 1; label < 256; ++label) {
    std::string name = total_class_name(static_cast<std::uint8_t>(label));
    if (name.empty()) continue;
    if (rename.count(name)) name = rename.at(name);
    const labels::TotalClass* cls = labels::find_total_class(name);
    EXPECT_NE(cls, nullptr) << name;
    if (cls) id[static_cast<std::uint8_t>(label)] = static_cast<std::uint8_t>(cls->id);
  }
  std::vector<std::uint8_t> values(truth.bone_label.data.size(), 0);
  for (std::size_t i = 0; i < values.size(); ++i) {
    const auto it = id.find(truth.bone_label.data[i]);
    if (it != id.end()) values[i] = it->second;
  }
  testing::write_label_nifti(out.labels, read_ct(out.ct).grid, values);
  return out;
}

Landmarks landmarks_with_labels(const testing::TempDir& dir, const TrunkWithLabels& files) {
  PrepParams params;
  params.use_cache = false;
  params.find_vessels = false;
  params.labels_path = files.labels;
  params.labels_map = kTotalSegmentatorMap;
  const std::string prep_dir = dir.file("prep");
  run_prep(files.ct, prep_dir, params);
  return find_landmarks(read_landmark_inputs(prep_dir, files.ct));
}

double distance(const Vec3d& a, const Vec3d& b) {
  return norm(a - b);
}

TEST(LandmarkLabels, EveryVertebraAndRibNamedFromTheLabels) {
  testing::TempDir dir;
  const Landmarks lm = landmarks_with_labels(dir, write_trunk(dir));
  const Landmarks truth = trunk_landmark_truth();
  for (const Vertebra& t : truth.vertebrae) {
    const Vertebra* v = find_vertebra(lm, *t.name);
    ASSERT_NE(v, nullptr) << *t.name;
    const double body = distance(v->body_centre, t.body_centre);
    std::printf("labelled %s body %.1f mm confidence %.2f\n", t.name->c_str(), body, v->confidence);
    EXPECT_GE(v->confidence, kLabelledConfidence) << *t.name << ": " << v->reason;
    EXPECT_TRUE(v->reason.empty()) << *t.name << ": " << v->reason;
    if (*t.name != "S") {
      EXPECT_LE(body, 5.0) << *t.name;
    }
  }
  for (const Rib& t : truth.ribs) {
    const Rib* r = find_rib(lm, t.side, *t.number);
    ASSERT_NE(r, nullptr) << "rib " << *t.number << " " << side_name(t.side);
    EXPECT_GE(r->confidence, kLabelledConfidence) << *t.number << ": " << r->reason;
  }
  for (const std::string& note : lm.notes)
    EXPECT_EQ(note.find("label map names"), std::string::npos) << note;
}

TEST(LandmarkLabels, AMislabelledVertebraAndRibKeepTheLabelsWithANote) {
  testing::TempDir dir;
  const Landmarks lm = landmarks_with_labels(
      dir, write_trunk(dir, {{"vertebrae_L3", "vertebrae_T1"}, {"rib_right_9", "rib_right_3"}}));
  // The labels win: "T1" where the count says L3, no L3.
  EXPECT_EQ(find_vertebra(lm, "L3"), nullptr);
  const Vertebra* v = find_vertebra(lm, "T1");
  ASSERT_NE(v, nullptr);
  EXPECT_EQ(v->confidence, kLabelDisagreesConfidence);
  EXPECT_NE(v->reason.find("label map"), std::string::npos) << v->reason;
  EXPECT_NE(v->reason.find("L3"), std::string::npos) << v->reason;
  // The others keep theirs, from the labels, agreeing with the count.
  for (const char* name : {"L5", "L4", "L2", "L1", "T12", "T8"}) {
    const Vertebra* other = find_vertebra(lm, name);
    ASSERT_NE(other, nullptr) << name;
    EXPECT_GE(other->confidence, kLabelledConfidence) << name;
  }
  EXPECT_EQ(find_rib(lm, Side::right, 9), nullptr);
  const Rib* r = find_rib(lm, Side::right, 3);
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->confidence, kLabelDisagreesConfidence);
  EXPECT_NE(r->reason.find("rib 9 right"), std::string::npos) << r->reason;
  int notes = 0;
  for (const std::string& note : lm.notes) {
    std::printf("note: %s\n", note.c_str());
    if (note.find("label map names T1") != std::string::npos &&
        note.find("L3") != std::string::npos)
      ++notes;
    if (note.find("rib_right_3") != std::string::npos &&
        note.find("rib 9 right") != std::string::npos)
      ++notes;
  }
  EXPECT_EQ(notes, 2);
}

TEST(LandmarkLabels, LabelNames) {
  EXPECT_EQ(vertebra_of_label("vertebrae_L3"), "L3");
  EXPECT_EQ(vertebra_of_label("sacrum"), "S");
  EXPECT_EQ(vertebra_of_label("vertebrae_S1"), "S");
  EXPECT_EQ(vertebra_of_label("rib_left_9"), "");
  int side = -1, number = 0;
  EXPECT_TRUE(parse_rib_label("rib_left_9", side, number));
  EXPECT_EQ(side, 1);
  EXPECT_EQ(number, 9);
  EXPECT_TRUE(parse_rib_label("rib_right_12", side, number));
  EXPECT_EQ(side, 0);
  EXPECT_EQ(number, 12);
  EXPECT_FALSE(parse_rib_label("rib_right_13", side, number));
  EXPECT_FALSE(parse_rib_label("vertebrae_L3", side, number));
}

}  // namespace
}  // namespace palp::anatomy
