// TotalSegmentator's `total` class map and the vocabulary for free-text names. See
// label_classes.hpp.
#include "prep/labels/label_classes.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <initializer_list>
#include <utility>
#include <vector>

namespace palp::labels {
namespace {

// The `total` task's class map (v2), ids and names as TotalSegmentator publishes them:
// github.com/wasserth/TotalSegmentator, totalsegmentator/map_to_binary.py, class_map["total"], at
// commit 0e65a448d557382b1e925276212b3bec7f5aff83 (2026-08-13; the map unchanged since
// 853cd2f, "reorder rib labels", 2024-03-14, released in v2.2.0; v2.0 and v2.1 numbered the ribs
// 92..107 in another order, all bone either way). The kinds and merged structures are palp's:
// the lung's lobes make one lung per side, a kidney's cyst (23, 24) joins that kidney and the
// left atrial appendage (61) the heart; pulmonary veins are veins; costal cartilages are bone
// (hard under the hand, on the ribs' ends); the paraspinal, gluteal and iliopsoas muscles are
// muscle.
constexpr std::array<TotalClass, kTotalClassCount> kTotal{{
    {1, "spleen", Kind::organ, nullptr},
    {2, "kidney_right", Kind::organ, nullptr},
    {3, "kidney_left", Kind::organ, nullptr},
    {4, "gallbladder", Kind::organ, nullptr},
    {5, "liver", Kind::organ, nullptr},
    {6, "stomach", Kind::organ, nullptr},
    {7, "pancreas", Kind::organ, nullptr},
    {8, "adrenal_gland_right", Kind::organ, nullptr},
    {9, "adrenal_gland_left", Kind::organ, nullptr},
    {10, "lung_upper_lobe_left", Kind::organ, "lung_left"},
    {11, "lung_lower_lobe_left", Kind::organ, "lung_left"},
    {12, "lung_upper_lobe_right", Kind::organ, "lung_right"},
    {13, "lung_middle_lobe_right", Kind::organ, "lung_right"},
    {14, "lung_lower_lobe_right", Kind::organ, "lung_right"},
    {15, "esophagus", Kind::organ, nullptr},
    {16, "trachea", Kind::organ, nullptr},
    {17, "thyroid_gland", Kind::organ, nullptr},
    {18, "small_bowel", Kind::organ, nullptr},
    {19, "duodenum", Kind::organ, nullptr},
    {20, "colon", Kind::organ, nullptr},
    {21, "urinary_bladder", Kind::organ, nullptr},
    {22, "prostate", Kind::organ, nullptr},
    {23, "kidney_cyst_left", Kind::organ, "kidney_left"},
    {24, "kidney_cyst_right", Kind::organ, "kidney_right"},
    {25, "sacrum", Kind::bone, nullptr},
    {26, "vertebrae_S1", Kind::bone, nullptr},
    {27, "vertebrae_L5", Kind::bone, nullptr},
    {28, "vertebrae_L4", Kind::bone, nullptr},
    {29, "vertebrae_L3", Kind::bone, nullptr},
    {30, "vertebrae_L2", Kind::bone, nullptr},
    {31, "vertebrae_L1", Kind::bone, nullptr},
    {32, "vertebrae_T12", Kind::bone, nullptr},
    {33, "vertebrae_T11", Kind::bone, nullptr},
    {34, "vertebrae_T10", Kind::bone, nullptr},
    {35, "vertebrae_T9", Kind::bone, nullptr},
    {36, "vertebrae_T8", Kind::bone, nullptr},
    {37, "vertebrae_T7", Kind::bone, nullptr},
    {38, "vertebrae_T6", Kind::bone, nullptr},
    {39, "vertebrae_T5", Kind::bone, nullptr},
    {40, "vertebrae_T4", Kind::bone, nullptr},
    {41, "vertebrae_T3", Kind::bone, nullptr},
    {42, "vertebrae_T2", Kind::bone, nullptr},
    {43, "vertebrae_T1", Kind::bone, nullptr},
    {44, "vertebrae_C7", Kind::bone, nullptr},
    {45, "vertebrae_C6", Kind::bone, nullptr},
    {46, "vertebrae_C5", Kind::bone, nullptr},
    {47, "vertebrae_C4", Kind::bone, nullptr},
    {48, "vertebrae_C3", Kind::bone, nullptr},
    {49, "vertebrae_C2", Kind::bone, nullptr},
    {50, "vertebrae_C1", Kind::bone, nullptr},
    {51, "heart", Kind::organ, nullptr},
    {52, "aorta", Kind::artery, nullptr},
    {53, "pulmonary_vein", Kind::vein, nullptr},
    {54, "brachiocephalic_trunk", Kind::artery, nullptr},
    {55, "subclavian_artery_right", Kind::artery, nullptr},
    {56, "subclavian_artery_left", Kind::artery, nullptr},
    {57, "common_carotid_artery_right", Kind::artery, nullptr},
    {58, "common_carotid_artery_left", Kind::artery, nullptr},
    {59, "brachiocephalic_vein_left", Kind::vein, nullptr},
    {60, "brachiocephalic_vein_right", Kind::vein, nullptr},
    {61, "atrial_appendage_left", Kind::organ, "heart"},
    {62, "superior_vena_cava", Kind::vein, nullptr},
    {63, "inferior_vena_cava", Kind::vein, nullptr},
    {64, "portal_vein_and_splenic_vein", Kind::vein, nullptr},
    {65, "iliac_artery_left", Kind::artery, nullptr},
    {66, "iliac_artery_right", Kind::artery, nullptr},
    {67, "iliac_vena_left", Kind::vein, nullptr},
    {68, "iliac_vena_right", Kind::vein, nullptr},
    {69, "humerus_left", Kind::bone, nullptr},
    {70, "humerus_right", Kind::bone, nullptr},
    {71, "scapula_left", Kind::bone, nullptr},
    {72, "scapula_right", Kind::bone, nullptr},
    {73, "clavicula_left", Kind::bone, nullptr},
    {74, "clavicula_right", Kind::bone, nullptr},
    {75, "femur_left", Kind::bone, nullptr},
    {76, "femur_right", Kind::bone, nullptr},
    {77, "hip_left", Kind::bone, nullptr},
    {78, "hip_right", Kind::bone, nullptr},
    {79, "spinal_cord", Kind::organ, nullptr},
    {80, "gluteus_maximus_left", Kind::muscle, nullptr},
    {81, "gluteus_maximus_right", Kind::muscle, nullptr},
    {82, "gluteus_medius_left", Kind::muscle, nullptr},
    {83, "gluteus_medius_right", Kind::muscle, nullptr},
    {84, "gluteus_minimus_left", Kind::muscle, nullptr},
    {85, "gluteus_minimus_right", Kind::muscle, nullptr},
    {86, "autochthon_left", Kind::muscle, nullptr},
    {87, "autochthon_right", Kind::muscle, nullptr},
    {88, "iliopsoas_left", Kind::muscle, nullptr},
    {89, "iliopsoas_right", Kind::muscle, nullptr},
    {90, "brain", Kind::organ, nullptr},
    {91, "skull", Kind::bone, nullptr},
    {92, "rib_left_1", Kind::bone, nullptr},
    {93, "rib_left_2", Kind::bone, nullptr},
    {94, "rib_left_3", Kind::bone, nullptr},
    {95, "rib_left_4", Kind::bone, nullptr},
    {96, "rib_left_5", Kind::bone, nullptr},
    {97, "rib_left_6", Kind::bone, nullptr},
    {98, "rib_left_7", Kind::bone, nullptr},
    {99, "rib_left_8", Kind::bone, nullptr},
    {100, "rib_left_9", Kind::bone, nullptr},
    {101, "rib_left_10", Kind::bone, nullptr},
    {102, "rib_left_11", Kind::bone, nullptr},
    {103, "rib_left_12", Kind::bone, nullptr},
    {104, "rib_right_1", Kind::bone, nullptr},
    {105, "rib_right_2", Kind::bone, nullptr},
    {106, "rib_right_3", Kind::bone, nullptr},
    {107, "rib_right_4", Kind::bone, nullptr},
    {108, "rib_right_5", Kind::bone, nullptr},
    {109, "rib_right_6", Kind::bone, nullptr},
    {110, "rib_right_7", Kind::bone, nullptr},
    {111, "rib_right_8", Kind::bone, nullptr},
    {112, "rib_right_9", Kind::bone, nullptr},
    {113, "rib_right_10", Kind::bone, nullptr},
    {114, "rib_right_11", Kind::bone, nullptr},
    {115, "rib_right_12", Kind::bone, nullptr},
    {116, "sternum", Kind::bone, nullptr},
    {117, "costal_cartilages", Kind::bone, nullptr},
}};

}  // namespace

const char* kind_name(Kind kind) {
  switch (kind) {
    case Kind::bone:
      return "bone";
    case Kind::artery:
      return "artery";
    case Kind::vein:
      return "vein";
    case Kind::vessel:
      return "vessel";
    case Kind::organ:
      return "organ";
    case Kind::muscle:
      return "muscle";
  }
  return "?";
}

std::span<const TotalClass> total_classes() {
  return kTotal;
}

const TotalClass* find_total_class(std::string_view name) {
  for (const TotalClass& cls : kTotal)
    if (name == cls.name) return &cls;
  return nullptr;
}

ClassMeaning meaning_of(const TotalClass& cls) {
  switch (cls.kind) {
    case Kind::bone:
    case Kind::artery:
    case Kind::vein:
    case Kind::vessel:
      return {cls.kind, kind_name(cls.kind)};
    case Kind::organ:
    case Kind::muscle:
      break;
  }
  return {cls.kind, cls.structure ? cls.structure : cls.name};
}

namespace {

// Lower case, every run of characters other than letters and digits one '_', none at the ends.
std::string normalized(std::string_view name) {
  std::string out;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u) && u < 128) {
      out += static_cast<char>(std::tolower(u));
    } else if (!out.empty() && out.back() != '_') {
      out += '_';
    }
  }
  if (!out.empty() && out.back() == '_') out.pop_back();
  return out;
}

std::vector<std::string> words_of(const std::string& normal) {
  std::vector<std::string> words;
  std::size_t start = 0;
  while (start <= normal.size()) {
    const std::size_t end = std::min(normal.find('_', start), normal.size());
    if (end > start) words.push_back(normal.substr(start, end - start));
    start = end + 1;
  }
  return words;
}

bool has_word(const std::vector<std::string>& words, std::initializer_list<std::string_view> set) {
  for (const std::string& w : words)
    for (const std::string_view s : set)
      if (w == s) return true;
  return false;
}

// English names for TotalSegmentator's classes that its own names do not cover.
constexpr std::pair<std::string_view, std::string_view> kSynonyms[] = {
    {"gall_bladder", "gallbladder"},    {"bladder", "urinary_bladder"},
    {"small_intestine", "small_bowel"}, {"large_intestine", "colon"},
    {"oesophagus", "esophagus"},        {"thyroid", "thyroid_gland"},
};

// A TotalSegmentator class or merged structure ("lung_left") of that normalized name.
std::optional<ClassMeaning> vocabulary(const std::string& normal) {
  std::string name = normal;
  for (const auto& [synonym, total] : kSynonyms)
    if (name == synonym) name = total;
  if (const TotalClass* cls = find_total_class(name)) return meaning_of(*cls);
  for (const TotalClass& cls : kTotal)
    if (cls.structure && name == cls.structure) return meaning_of(cls);
  return std::nullopt;
}

// "left kidney", "kidney left", "kidney (left)" -> "kidney_left".
std::optional<ClassMeaning> sided_vocabulary(const std::vector<std::string>& words) {
  for (const std::string_view side : {"left", "right"}) {
    if (std::count(words.begin(), words.end(), side) != 1) continue;
    std::string rest;
    for (const std::string& w : words)
      if (w != side) rest += (rest.empty() ? "" : "_") + w;
    if (auto meaning = vocabulary(rest + "_" + std::string(side))) return meaning;
  }
  return std::nullopt;
}

std::optional<Kind> kind_from_words(const std::vector<std::string>& words) {
  const bool artery =
      has_word(words, {"artery", "arteries", "arterial", "aorta", "aortic", "carotid", "arteria"});
  const bool vein = has_word(words, {"vein", "veins", "vena", "venae", "venous", "cava"});
  if (artery && !vein) return Kind::artery;
  if (vein && !artery) return Kind::vein;
  if (artery || has_word(words, {"vessel", "vessels", "vascular", "vasculature"}))
    return Kind::vessel;
  if (has_word(words, {"bone",      "bones",     "bony",    "rib",     "ribs",     "vertebra",
                       "vertebrae", "vertebral", "spine",   "skull",   "sacrum",   "coccyx",
                       "pelvis",    "femur",     "humerus", "scapula", "clavicle", "clavicula",
                       "sternum",   "skeleton",  "hip",     "ilium",   "ischium",  "pubis",
                       "mandible",  "tibia",     "fibula",  "radius",  "ulna",     "patella",
                       "cartilage", "cartilages"}))
    return Kind::bone;
  return std::nullopt;
}

}  // namespace

NameMeaning classify_name(std::string_view name) {
  const std::string normal = normalized(name);
  if (auto meaning = vocabulary(normal)) return {*meaning, true};
  const std::vector<std::string> words = words_of(normal);
  if (auto meaning = sided_vocabulary(words)) return {*meaning, true};
  if (const auto kind = kind_from_words(words)) return {{*kind, kind_name(*kind)}, true};
  return {{Kind::organ, normal}, false};
}

std::optional<std::string> structure_file_name(std::string_view name) {
  if (name.empty() || name.size() > 64) return std::nullopt;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (!(u < 128 && (std::isalnum(u) || c == ' ' || c == '-' || c == '_'))) return std::nullopt;
  }
  const std::string file = normalized(name);
  if (file.empty()) return std::nullopt;
  for (const std::string_view own : {"body", "bone", "vessel", "ct", "prep", "structures"})
    if (file == own) return std::nullopt;
  if (file.rfind("d_", 0) == 0) return std::nullopt;
  return file;
}

namespace {

// A vertebral level "C1".."C7", "T1".."T12", "L1".."L5" (or "L6", a transitional one), "S1";
// null for anything else.
std::optional<std::string> vertebral_level(const std::string& token) {
  if (token.size() < 2 || token.size() > 3) return std::nullopt;
  const char region = static_cast<char>(std::toupper(static_cast<unsigned char>(token[0])));
  for (std::size_t i = 1; i < token.size(); ++i)
    if (!std::isdigit(static_cast<unsigned char>(token[i]))) return std::nullopt;
  const int n = std::stoi(token.substr(1));
  const int most = region == 'C'   ? 7
                   : region == 'T' ? 12
                   : region == 'L' ? 6
                   : region == 'S' ? 1
                                   : 0;
  if (n < 1 || n > most) return std::nullopt;
  std::string level(1, region);
  level += std::to_string(n);
  return level;
}

// A rib's number from "9", "9th", "1st", "2nd", "3rd"; null for anything else.
std::optional<int> rib_number(std::string token) {
  for (const char* suffix : {"st", "nd", "rd", "th"})
    if (token.size() > 2 && token.ends_with(suffix)) token.resize(token.size() - 2);
  if (token.empty() || token.size() > 2) return std::nullopt;
  for (char c : token)
    if (!std::isdigit(static_cast<unsigned char>(c))) return std::nullopt;
  const int n = std::stoi(token);
  return n >= 1 && n <= 12 ? std::optional<int>(n) : std::nullopt;
}

}  // namespace

std::optional<std::string> skeleton_name(std::string_view name) {
  std::vector<std::string> tokens(1);
  for (char c : name) {
    if (c == '_' || c == ' ' || c == '-') {
      if (!tokens.back().empty()) tokens.emplace_back();
    } else {
      tokens.back() += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    }
  }
  if (tokens.back().empty()) tokens.pop_back();
  if (tokens.size() == 1 && tokens[0] == "sacrum") return "sacrum";
  bool vertebra = false, rib = false;
  std::optional<std::string> level, side;
  std::optional<int> number;
  for (const std::string& t : tokens) {
    vertebra |= t == "vertebra" || t == "vertebrae";
    rib |= t == "rib" || t == "ribs";
    if (t == "left" || t == "right") side = t;
    if (auto l = vertebral_level(t)) level = l;
    if (auto n = rib_number(t)) number = n;
  }
  if (level && !rib && (vertebra || tokens.size() == 1)) return "vertebrae_" + *level;
  if (rib && !vertebra && side && number) return "rib_" + *side + "_" + std::to_string(*number);
  return std::nullopt;
}

}  // namespace palp::labels
