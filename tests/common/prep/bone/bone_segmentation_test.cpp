// The bone mask (common/prep/bone/bone_segmentation.cpp) against the expert labels of the shared CT
// (../shared/data/ct_abdomen_3mm_reference_labels.nii.gz: 1 organs, 2 bone), measured only: the
// labels never enter the segmentation. Skips when the data is absent.
#include <gtest/gtest.h>

#include <cstdlib>

#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>

#include "io/ct_io.hpp"
#include "prep/segment/hu_levels.hpp"
#include "prep/segment/segmentation.hpp"
#include "support/bone_error_split.hpp"
#include "support/mask_metrics.hpp"
#include "support/shared_ct_labels.hpp"

namespace palp {
namespace {

struct Measured {
  double dice = 0.0;
  double precision = 0.0;  // of the segmented bone, the share the experts call bone
  double recall = 0.0;     // of the experts' bone, the share segmented
  double assd_mm = 0.0;
  double superficial_recall = 0.0;  // see below
  std::int64_t superficial_voxels = 0;
  std::int64_t organ_voxels_outside_body = 0;
  // The same away from the hip prosthesis (see far_from_metal): Dice and ASSD.
  double dice_away = 0.0;
  double assd_away_mm = 0.0;
};

// HU no bone reaches (cortical bone stays below ~2000 HU): a metal implant.
constexpr double kMetalHu = 2500.0;
// Around the shared CT's right hip prosthesis the experts' labels hold the implant (93 % of its
// voxels >= 2500 HU are bone) but not the proximal femur around it: the ring of 150-650 HU
// around the stem and the trochanter lateral to it, a region the size and place of the left
// proximal femur, which they label whole; it reaches about 45 mm from the metal. That region is
// measured apart: voxels farther than this from any metal voxel.
constexpr double kMetalMarginMm = 50.0;

Mask far_from_metal(const CtVolume& ct, double margin_mm) {
  Mask metal(ct.grid, 0);
  for (std::size_t n = 0; n < metal.data.size(); ++n) metal.data[n] = ct.data[n] >= kMetalHu;
  const std::vector<double> d2 = testing::squared_distance_to(metal);
  Mask far(ct.grid, 0);
  for (std::size_t n = 0; n < far.data.size(); ++n) far.data[n] = d2[n] > margin_mm * margin_mm;
  return far;
}

struct SharedCt {
  CtVolume ct;
  Mask body, truth_bone, organs, superficial, away_from_metal;
  HuLevels levels;
  double metal_margin_mm = 0.0;
};

// The shared CT, its body mask and the expert labels; false when the data is absent.
bool load_shared_ct(SharedCt& d) {
  testing::LabelledCt labelled;
  if (!testing::load_labelled_shared_ct(labelled)) return false;
  d.ct = std::move(labelled.ct);
  d.truth_bone = std::move(labelled.truth_bone);
  d.organs = std::move(labelled.organs);
  d.body = segment_body(d.ct, SegmentationParams{});
  // The levels as prep sets them: shifted with the scan's soft-tissue peak
  // (prep/segment/hu_levels.hpp).
  d.levels = estimate_hu_levels(d.ct, d.body);
  d.superficial = testing::superficial_bone(d.truth_bone, d.body);
  // PALP_BONE_METAL_MARGIN_MM=X: another margin (docs/notebook/prep.md lists 30, 50 and 80 mm).
  const char* margin = std::getenv("PALP_BONE_METAL_MARGIN_MM");
  d.metal_margin_mm = margin ? std::atof(margin) : kMetalMarginMm;
  d.away_from_metal = far_from_metal(d.ct, d.metal_margin_mm);
  return true;
}

// The bone mask with `params`, its levels adapted as prep adapts them (nominal + the scan's offset)
// unless `adapt` is false, against the labels.
Measured measure(const SharedCt& d, SegmentationParams params, bool adapt = true) {
  if (adapt) {
    params.bone_seed_hu += d.levels.offset_hu;
    params.bone_grow_hu += d.levels.offset_hu;
  }
  const Mask bone = segment_bone(d.ct, d.body, params);
  Measured m;
  m.dice = testing::dice(bone, d.truth_bone);
  m.assd_mm = testing::mean_surface_distance(bone, d.truth_bone);
  const auto both = static_cast<double>(testing::count_both(bone, d.truth_bone));
  m.precision = both / static_cast<double>(testing::count(bone));
  m.recall = both / static_cast<double>(testing::count(d.truth_bone));
  m.organ_voxels_outside_body = testing::count_and_not(d.organs, d.body);
  m.dice_away = testing::dice_within(bone, d.truth_bone, d.away_from_metal);
  m.assd_away_mm = testing::mean_surface_distance(bone, d.truth_bone, &d.away_from_metal);
  m.superficial_voxels = testing::count(d.superficial);
  m.superficial_recall = static_cast<double>(testing::count_both(d.superficial, bone)) /
                         static_cast<double>(m.superficial_voxels);
  return m;
}

void print_row(const char* name, const Measured& m) {
  std::printf("| %s | %.3f | %.3f | %.3f | %.2f | %.3f | %.3f | %.2f |\n", name, m.dice,
              m.precision, m.recall, m.assd_mm, m.superficial_recall, m.dice_away, m.assd_away_mm);
}

TEST(BoneSegmentation, AgainstExpertLabelsOfTheSharedCt) {
  SharedCt d;
  if (!load_shared_ct(d)) GTEST_SKIP() << "the shared CT or its labels are not in the data folder";
  const bool fixed = std::getenv("PALP_FIXED_BONE_LEVELS") != nullptr;
  const SegmentationParams params;
  std::printf("bone levels: seed %.0f, grow %.0f HU (offset %.0f%s)\n",
              params.bone_seed_hu + (fixed ? 0.0 : d.levels.offset_hu),
              params.bone_grow_hu + (fixed ? 0.0 : d.levels.offset_hu), d.levels.offset_hu,
              fixed ? ", not applied" : "");
  const Measured m = measure(d, params, !fixed);
  std::printf(
      "bone vs experts: Dice %.3f, precision %.3f, recall %.3f, mean symmetric surface distance "
      "%.2f mm, superficial "
      "anterolateral (rib region) recall %.3f of %lld voxels; organ voxels outside the body %lld\n",
      m.dice, m.precision, m.recall, m.assd_mm, m.superficial_recall,
      static_cast<long long>(m.superficial_voxels),
      static_cast<long long>(m.organ_voxels_outside_body));
  std::int64_t metal = 0, metal_bone = 0;
  for (std::size_t n = 0; n < d.ct.data.size(); ++n) {
    metal += d.ct.data[n] >= kMetalHu;
    metal_bone += d.ct.data[n] >= kMetalHu && d.truth_bone.data[n];
  }
  std::printf("metal (>= %.0f HU): %lld voxels, %lld of them bone in the labels\n", kMetalHu,
              static_cast<long long>(metal), static_cast<long long>(metal_bone));
  std::printf("farther than %.0f mm from metal: Dice %.3f, ASSD %.2f mm\n", d.metal_margin_mm,
              m.dice_away, m.assd_away_mm);
  EXPECT_EQ(m.organ_voxels_outside_body, 0);
  EXPECT_GT(m.superficial_voxels, 1000);
  if (fixed) return;
  // What the method achieves (docs/prep.md: Dice 0.898, precision 0.905, 1.10 mm, rib region
  // 0.889). The goal, Dice >= 0.90 and <= 1.0 mm, is not met on the whole scan; away from
  // the prosthesis, where the labels hold the bone, both are met (Dice 0.907, 0.85 mm).
  EXPECT_GE(m.dice, 0.8975);
  EXPECT_LE(m.assd_mm, 1.105);
  EXPECT_GE(m.superficial_recall, 0.885);
  if (d.metal_margin_mm == kMetalMarginMm) {
    EXPECT_GE(m.dice_away, 0.905);
    EXPECT_LE(m.assd_away_mm, 0.855);
  }
  EXPECT_GE(m.precision, 0.89);  // over-segmentation (vessels, calcifications, table) stays rare
}

// The variants of docs/notebook/prep.md's table, one row each (PALP_BONE_VARIANTS=1; they take a few
// seconds, so the suite skips them).
TEST(BoneSegmentation, VariantsTable) {
  if (std::getenv("PALP_BONE_VARIANTS") == nullptr) GTEST_SKIP() << "set PALP_BONE_VARIANTS=1";
  SharedCt d;
  if (!load_shared_ct(d)) GTEST_SKIP() << "the shared CT or its labels are not in the data folder";
  std::printf(
      "| variant | Dice | precision | recall | ASSD mm | rib recall | Dice away from metal | ASSD "
      "away mm |\n");
  const SegmentationParams base;
  print_row(
      "default: grow 150, 2 of 3 planes, enclosure 12 mm 10 of 13, plates 20 mm, edge 0.3, notches "
      "4 of 6 faces, calculi up to 30 mm",
      measure(d, base));
  print_row("the same, levels not adapted", measure(d, base, false));
  for (const double edge : {0.0, 0.1, 0.2, 0.4, 0.5}) {
    SegmentationParams p = base;
    p.bone_edge_fraction = edge;
    const std::string name = "edge " + std::to_string(edge).substr(0, 3);
    print_row(name.c_str(), measure(d, p));
  }
  for (const int votes : {1, 3}) {
    SegmentationParams p = base;
    p.bone_marrow_votes = votes;
    const std::string name = std::to_string(votes) + " of 3 planes";
    print_row(name.c_str(), measure(d, p));
  }
  for (const double grow : {100.0, 125.0, 175.0}) {
    SegmentationParams p = base;
    p.bone_grow_hu = grow;
    const std::string name = "grow " + std::to_string(static_cast<int>(grow));
    print_row(name.c_str(), measure(d, p));
  }
  {
    SegmentationParams p = base;
    p.bone_enclosure_directions = 0;
    print_row("no enclosure", measure(d, p));
  }
  for (const double plate : {0.0, 15.0, 25.0, 30.0}) {
    SegmentationParams p = base;
    p.bone_plate_radius_mm = plate;
    const std::string name =
        plate == 0.0 ? std::string("no plate rule")
                     : "plate radius " + std::to_string(static_cast<int>(plate)) + " mm";
    print_row(name.c_str(), measure(d, p));
  }
  for (const double radius : {9.0, 15.0, 20.0})
    for (const int lines : {9, 10, 11}) {
      SegmentationParams p = base;
      p.bone_enclosure_radius_mm = radius;
      p.bone_enclosure_directions = lines;
      const std::string name = "enclosure " + std::to_string(static_cast<int>(radius)) + " mm, " +
                               std::to_string(lines) + " of 13";
      print_row(name.c_str(), measure(d, p));
    }
  for (const int lines : {8, 9, 11}) {
    SegmentationParams p = base;
    p.bone_enclosure_directions = lines;
    const std::string name = "enclosure 12 mm, " + std::to_string(lines) + " of 13";
    print_row(name.c_str(), measure(d, p));
  }
  for (const int faces : {0, 5, 6}) {
    SegmentationParams p = base;
    p.bone_notch_faces = faces;
    const std::string name = faces == 0
                                 ? std::string("no notch fill (the default before the notches)")
                                 : "notches " + std::to_string(faces) + " of 6 faces";
    print_row(name.c_str(), measure(d, p));
  }
  for (const double edge : {0.2, 0.5}) {
    SegmentationParams p = base;
    p.bone_notch_faces = 0;
    p.bone_edge_fraction = edge;
    const std::string name = "no notch fill, edge " + std::to_string(edge).substr(0, 3);
    print_row(name.c_str(), measure(d, p));
  }
  for (const double island : {1.0, 1.5}) {
    SegmentationParams p = base;
    p.min_bone_island_ml = island;
    const std::string name = "islands under " + std::to_string(island).substr(0, 3) + " ml removed";
    print_row(name.c_str(), measure(d, p));
  }
  for (const double length : {0.0, 15.0, 45.0}) {
    SegmentationParams p = base;
    p.bone_calculus_max_length_mm = length;
    const std::string name =
        length == 0.0 ? std::string("no calculus rule (the previous default)")
                      : "calculi up to " + std::to_string(static_cast<int>(length)) + " mm long";
    print_row(name.c_str(), measure(d, p));
  }
  for (const double hole : {1000.0, 1e9}) {
    SegmentationParams p = base;
    p.bone_max_hole_mm2 = hole;
    const std::string name = "holes up to " + std::to_string(static_cast<long long>(hole)) + " mm2";
    print_row(name.c_str(), measure(d, p));
  }
}

// Where the default mask's errors lie (PALP_BONE_DIAG=1; support/bone_error_split.hpp).
TEST(BoneSegmentation, ErrorSplit) {
  if (std::getenv("PALP_BONE_DIAG") == nullptr) GTEST_SKIP() << "set PALP_BONE_DIAG=1";
  SharedCt d;
  if (!load_shared_ct(d)) GTEST_SKIP() << "the shared CT or its labels are not in the data folder";
  SegmentationParams params;
  params.bone_seed_hu += d.levels.offset_hu;
  params.bone_grow_hu += d.levels.offset_hu;
  const Mask bone = segment_bone(d.ct, d.body, params);
  testing::print_bone_error_split(d.ct, d.body, bone, d.truth_bone);
  testing::print_pieces(d.ct, bone, d.truth_bone, "false positives", 15);
  testing::print_pieces(d.ct, d.truth_bone, bone, "false negatives", 15);
  // PALP_BONE_DUMP=FILE: the CT (int16), our mask and the experts' bone (uint8 each), raw, for
  // viewing slices.
  if (const char* dump = std::getenv("PALP_BONE_DUMP")) {
    std::FILE* f = std::fopen(dump, "wb");
    ASSERT_NE(f, nullptr);
    std::fwrite(d.ct.data.data(), sizeof(d.ct.data[0]), d.ct.size(), f);
    std::fwrite(bone.data.data(), 1, bone.size(), f);
    std::fwrite(d.truth_bone.data.data(), 1, bone.size(), f);
    std::fclose(f);
  }
}

}  // namespace
}  // namespace palp
