// Tests for label_classes.hpp: TotalSegmentator's `total` class map against ids read from its own
// source (github.com/wasserth/TotalSegmentator, totalsegmentator/map_to_binary.py, class_map
// ["total"], commit 0e65a448d557382b1e925276212b3bec7f5aff83), palp's kinds for its classes, and
// the vocabulary for free-text (3D Slicer) names.
#include "prep/labels/label_classes.hpp"

#include <gtest/gtest.h>

#include <set>

namespace palp::labels {
namespace {

int id_of(const char* name) {
  const TotalClass* cls = find_total_class(name);
  return cls ? cls->id : -1;
}

TEST(TotalClasses, IdsAsTotalSegmentatorPublishesThem) {
  EXPECT_EQ(id_of("spleen"), 1);
  EXPECT_EQ(id_of("kidney_right"), 2);
  EXPECT_EQ(id_of("kidney_left"), 3);
  EXPECT_EQ(id_of("liver"), 5);
  EXPECT_EQ(id_of("pancreas"), 7);
  EXPECT_EQ(id_of("sacrum"), 25);
  EXPECT_EQ(id_of("vertebrae_L1"), 31);
  EXPECT_EQ(id_of("heart"), 51);
  EXPECT_EQ(id_of("aorta"), 52);
  EXPECT_EQ(id_of("inferior_vena_cava"), 63);
  EXPECT_EQ(id_of("portal_vein_and_splenic_vein"), 64);
  EXPECT_EQ(id_of("iliac_artery_left"), 65);
  EXPECT_EQ(id_of("iliac_vena_right"), 68);
  EXPECT_EQ(id_of("femur_left"), 75);
  EXPECT_EQ(id_of("skull"), 91);
  EXPECT_EQ(id_of("rib_left_1"), 92);
  EXPECT_EQ(id_of("rib_right_12"), 115);
  EXPECT_EQ(id_of("sternum"), 116);
  EXPECT_EQ(id_of("costal_cartilages"), 117);
  EXPECT_EQ(id_of("Liver"), -1);  // TotalSegmentator's spelling only
  // 1..117 in order, each name once.
  std::set<std::string> names;
  int expected = 1;
  for (const TotalClass& cls : total_classes()) {
    EXPECT_EQ(cls.id, expected++);
    EXPECT_TRUE(names.insert(cls.name).second) << cls.name;
  }
  EXPECT_EQ(expected, kTotalClassCount + 1);
}

ClassMeaning total(const char* name) {
  return meaning_of(*find_total_class(name));
}

TEST(TotalClasses, KindsAndStructures) {
  for (const char* bone :
       {"vertebrae_T12", "rib_left_7", "sacrum", "hip_right", "femur_right", "humerus_left",
        "scapula_left", "clavicula_right", "sternum", "costal_cartilages", "skull"}) {
    EXPECT_EQ(total(bone).kind, Kind::bone) << bone;
    EXPECT_EQ(total(bone).structure, "bone") << bone;
  }
  for (const char* artery : {"aorta", "brachiocephalic_trunk", "common_carotid_artery_left",
                             "subclavian_artery_right", "iliac_artery_left"})
    EXPECT_EQ(total(artery).kind, Kind::artery) << artery;
  for (const char* vein :
       {"inferior_vena_cava", "superior_vena_cava", "portal_vein_and_splenic_vein",
        "iliac_vena_left", "brachiocephalic_vein_right", "pulmonary_vein"})
    EXPECT_EQ(total(vein).kind, Kind::vein) << vein;
  EXPECT_EQ(total("liver").kind, Kind::organ);
  EXPECT_EQ(total("liver").structure, "liver");
  EXPECT_EQ(total("lung_middle_lobe_right").structure, "lung_right");
  EXPECT_EQ(total("lung_upper_lobe_left").structure, "lung_left");
  EXPECT_EQ(total("kidney_cyst_left").structure, "kidney_left");
  EXPECT_EQ(total("atrial_appendage_left").structure, "heart");
  EXPECT_EQ(total("gluteus_maximus_left").kind, Kind::muscle);
  EXPECT_EQ(total("gluteus_maximus_left").structure, "gluteus_maximus_left");
  std::size_t bones = 0, arteries = 0, veins = 0;
  for (const TotalClass& cls : total_classes()) {
    bones += cls.kind == Kind::bone;
    arteries += cls.kind == Kind::artery;
    veins += cls.kind == Kind::vein;
  }
  // 25 vertebrae, 24 ribs, sacrum, skull, sternum, costal cartilages, 10 limb-girdle bones.
  EXPECT_EQ(bones, 63u);
  EXPECT_EQ(arteries, 8u);
  EXPECT_EQ(veins, 8u);
}

TEST(ClassifyName, SlicerNames) {
  const auto is = [](const char* name, Kind kind, const char* structure, bool known = true) {
    const NameMeaning m = classify_name(name);
    EXPECT_EQ(m.meaning.kind, kind) << name;
    EXPECT_EQ(m.meaning.structure, structure) << name;
    EXPECT_EQ(m.known, known) << name;
  };
  is("Liver", Kind::organ, "liver");
  is("kidney_left", Kind::organ, "kidney_left");
  is("Left kidney", Kind::organ, "kidney_left");
  is("right lung", Kind::organ, "lung_right");
  is("Gall bladder", Kind::organ, "gallbladder");
  is("Inferior vena cava", Kind::vein, "vein");
  is("portal vein", Kind::vein, "vein");
  is("Aorta", Kind::artery, "artery");
  is("left femoral artery", Kind::artery, "artery");
  is("vertebral artery", Kind::artery, "artery");  // the vessel, not the bone
  is("arteries and veins", Kind::vessel, "vessel");
  is("Vessels", Kind::vessel, "vessel");
  is("ribs", Kind::bone, "bone");
  is("cervical vertebral column", Kind::bone, "bone");
  is("Bone", Kind::bone, "bone");
  is("Costal cartilages", Kind::bone, "bone");
  is("spinal cord", Kind::organ, "spinal_cord");
  is("Tumor 1", Kind::organ, "tumor_1", false);
  is("tissue", Kind::organ, "tissue", false);
}

TEST(ClassifyName, FileNames) {
  EXPECT_EQ(structure_file_name("Tumor 1"), "tumor_1");
  EXPECT_EQ(structure_file_name("lymph-node  left"), "lymph_node_left");
  EXPECT_EQ(structure_file_name("Tumor/1"), std::nullopt);
  EXPECT_EQ(structure_file_name("../x"), std::nullopt);
  EXPECT_EQ(structure_file_name("Lèsion"), std::nullopt);
  EXPECT_EQ(structure_file_name(""), std::nullopt);
  EXPECT_EQ(structure_file_name("   "), std::nullopt);
  EXPECT_EQ(structure_file_name(std::string(65, 'a')), std::nullopt);
  EXPECT_EQ(structure_file_name("Body"), std::nullopt);  // prep's body.nii.gz
  EXPECT_EQ(structure_file_name("CT"), std::nullopt);
  EXPECT_EQ(structure_file_name("d_liver"), std::nullopt);  // a distance map's name
}

TEST(LabelClasses, SkeletonNamesFromTotalSegmentatorAndFreeText) {
  EXPECT_EQ(skeleton_name("vertebrae_L3"), "vertebrae_L3");
  EXPECT_EQ(skeleton_name("vertebrae_T12"), "vertebrae_T12");
  EXPECT_EQ(skeleton_name("vertebrae_S1"), "vertebrae_S1");
  EXPECT_EQ(skeleton_name("sacrum"), "sacrum");
  EXPECT_EQ(skeleton_name("rib_left_9"), "rib_left_9");
  EXPECT_EQ(skeleton_name("Rib right 12"), "rib_right_12");
  EXPECT_EQ(skeleton_name("left rib 9"), "rib_left_9");
  EXPECT_EQ(skeleton_name("9th rib left"), "rib_left_9");
  EXPECT_EQ(skeleton_name("L3 vertebra"), "vertebrae_L3");
  EXPECT_EQ(skeleton_name("T8"), "vertebrae_T8");
  EXPECT_FALSE(skeleton_name("femur_left"));
  EXPECT_FALSE(skeleton_name("rib 13 left"));
  EXPECT_FALSE(skeleton_name("vertebrae_L9"));
  EXPECT_FALSE(skeleton_name("costal_cartilages"));
  EXPECT_FALSE(skeleton_name("liver"));
}

}  // namespace
}  // namespace palp::labels
