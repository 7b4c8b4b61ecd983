// The anatomical landmarks of one scan (spec "Files": `palp landmarks`): what a trainee palpates
// for before a needle, every point in the patient's LPS world frame (mm; x = patient left,
// y = posterior, z = superior). Each landmark carries a confidence in [0, 1]; where the scan
// cannot support it (a thin slab, no sacrum and no T12 to number from, no vessel), its point or
// number is absent (`null` in JSON) and `reason` says why: never a guess.
//
// This header is the data and its JSON only (landmark_detection.hpp finds them in a scene;
// the training tasks read them). JSON: one object with the arrays below, members named as here.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "base/vec.hpp"

namespace palp::anatomy {

enum class Side { right, left };             // the patient's
const char* side_name(Side side);            // "right", "left"
std::optional<Side> parse_side(std::string_view text);  // "right"/"left"/"r"/"l"

// A rib: its side, its number (1-12, from the vertebra its head articulates with) and points
// along it from the head outward (LPS mm), as many as the scan shows.
struct Rib {
  Side side = Side::right;
  std::optional<int> number;
  std::vector<Vec3d> points;
  double confidence = 0.0;
  std::string reason;  // why `number` is absent or uncertain; empty when nothing to say
};

// The intercostal space below rib `upper_rib` on `side`: the point on the skin at the
// mid-axillary line, midway between the two ribs, and the skin's outward unit normal there.
struct IntercostalSpace {
  Side side = Side::right;
  std::optional<int> upper_rib;
  std::optional<Vec3d> skin_point;
  std::optional<Vec3d> normal;
  double confidence = 0.0;
  std::string reason;
};

// A vertebra: its name (C1..C7, T1..T12, L1..L5, S for the sacrum), or absent when the scan
// cannot number it; its body's centre and its spinous process's tip (absent on the sacrum or
// when the scan cuts it).
struct Vertebra {
  std::optional<std::string> name;
  Vec3d body_centre{};
  std::optional<Vec3d> spinous_tip;
  double confidence = 0.0;
  std::string reason;
};

// The top (most superior point) of an iliac crest.
struct IliacCrest {
  Side side = Side::right;
  std::optional<Vec3d> top;
  double confidence = 0.0;
  std::string reason;
};

// Tuffier's (the intercristal) line: the superior-inferior level (LPS z, mm) of the iliac
// crests' tops, and the vertebral level it crosses ("L4", "L4/L5") where the spine is numbered.
struct TuffierLine {
  std::optional<double> z_mm;
  std::optional<std::string> vertebral_level;
  double confidence = 0.0;
  std::string reason;
};

// A lumbar interspace ("L3/L4"): the skin entry point on the midline between the two spinous
// processes, and the skin's outward normal there.
struct LumbarInterspace {
  std::string name;
  std::optional<Vec3d> skin_point;
  std::optional<Vec3d> normal;
  double confidence = 0.0;
  std::string reason;
};

// Where the common femoral artery's pulse is felt on a side: on the skin over the artery when
// the scan or its labels show it (source "artery"), else over the mid-inguinal point from the
// bones (midway between the anterior superior iliac spine and the pubic symphysis; source
// "mid-inguinal").
struct FemoralPulsePoint {
  Side side = Side::right;
  std::optional<Vec3d> skin_point;
  std::optional<Vec3d> normal;
  std::string source;  // "artery" | "mid-inguinal" | "" when absent
  double confidence = 0.0;
  std::string reason;
};

struct Landmarks {
  std::string scene;               // what they were found in (a path or phantom:NAME)
  std::vector<std::string> notes;  // what the scan could not show, as sentences
  std::vector<Rib> ribs;
  std::vector<IntercostalSpace> intercostal_spaces;
  std::vector<Vertebra> vertebrae;  // inferior to superior
  std::vector<IliacCrest> iliac_crests;
  TuffierLine tuffier_line;
  std::vector<LumbarInterspace> lumbar_interspaces;
  std::vector<FemoralPulsePoint> femoral_pulse_points;
};

// The JSON text (2-space indented, numbers to 0.01 mm / 0.001 confidence).
std::string landmarks_to_json(const Landmarks& landmarks);
// Parses it back; InputError naming `name` on anything malformed (wrong types, a side that is
// not right/left, a confidence outside [0, 1], a non-finite number, more than kMaxLandmarkItems
// entries in an array or kMaxRibPoints points on a rib).
Landmarks landmarks_from_json(std::string_view text, const std::string& name);
// Files: written under a temporary name and renamed; read bounded by kMaxLandmarksFileBytes.
void write_landmarks(const std::string& path, const Landmarks& landmarks);
Landmarks read_landmarks(const std::string& path);

inline constexpr std::size_t kMaxLandmarkItems = 256;
inline constexpr std::size_t kMaxRibPoints = 512;
inline constexpr std::uintmax_t kMaxLandmarksFileBytes = std::uintmax_t{4} << 20;

// Lookups the tasks use: nullptr when absent.
const IntercostalSpace* find_intercostal_space(const Landmarks& landmarks, Side side,
                                               int upper_rib);
const LumbarInterspace* find_lumbar_interspace(const Landmarks& landmarks, std::string_view name);
const FemoralPulsePoint* find_femoral_pulse_point(const Landmarks& landmarks, Side side);
const Rib* find_rib(const Landmarks& landmarks, Side side, int number);
const Vertebra* find_vertebra(const Landmarks& landmarks, std::string_view name);

}  // namespace palp::anatomy
