// What the class names of a label file mean to palp: TotalSegmentator's `total` task class map
// (v2, ids 1..117) with each class sorted into bone, artery, vein, organ or muscle, and the
// vocabulary that sorts free-text names (3D Slicer's segments) the same way.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace palp::labels {

// bone, artery, vein: unions (the bone mask, the vessel mask split into arteries and veins);
// vessel: a vessel named neither artery nor vein; organ, muscle: a structure of its own.
enum class Kind { bone, artery, vein, vessel, organ, muscle };

const char* kind_name(Kind kind);

// Where a class goes: its kind and the structure it joins ("bone", "artery", "vein", "vessel"
// for the unions; an organ's or muscle's own name, or the one it is merged into).
struct ClassMeaning {
  Kind kind = Kind::organ;
  std::string structure;
};

// One class of TotalSegmentator's `total` task. `structure` is null when the class is a structure
// of its own (organs, muscles) or joins its kind's union (bone, arteries, veins).
struct TotalClass {
  int id;
  const char* name;
  Kind kind;
  const char* structure;
};

inline constexpr int kTotalClassCount = 117;

// The `total` task's classes, ids 1..117 in order.
std::span<const TotalClass> total_classes();
// The class of that exact name (TotalSegmentator's own spelling), or null.
const TotalClass* find_total_class(std::string_view name);
ClassMeaning meaning_of(const TotalClass& cls);

// A free-text name (a 3D Slicer segment): TotalSegmentator's names and the structures they join
// in any case, with spaces or hyphens for underscores and "left X" for "X_left"; a few English
// synonyms; else words: vessel words (artery, aorta, vein, vena, vessel, ...) before bone words
// (bone, rib, vertebra, skull, femur, ...). Anything else is an organ of its own name (`known`
// false); its structure is the name made a file name (see structure_file_name).
struct NameMeaning {
  ClassMeaning meaning;
  bool known = false;
};
NameMeaning classify_name(std::string_view name);

// A name as a structure's file name: lower case, runs of spaces, '-' and '_' one '_'. Null when
// it holds anything but ASCII letters, digits, spaces, '-' and '_', is empty, longer than 64
// characters, or would be one of prep's own files (body, bone, vessel, ct, prep, structures,
// d_*).
std::optional<std::string> structure_file_name(std::string_view name);

// The skeleton element a bone class names, as TotalSegmentator spells it: "vertebrae_L3",
// "vertebrae_T12", "vertebrae_S1", "sacrum", "rib_left_9", "rib_right_12"; null for any other
// bone (or no bone). Read from TotalSegmentator's names and free text alike (3D Slicer's segments:
// any case, spaces or hyphens for underscores, "L3 vertebra", "left rib 9", "rib 9 right",
// "9th rib left").
std::optional<std::string> skeleton_name(std::string_view name);

}  // namespace palp::labels
