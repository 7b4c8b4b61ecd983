// The landmarks' JSON: written with fixed precision, read strictly and within bounds.
#include "anatomy/landmarks.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <system_error>

#include "base/errors.hpp"
#include "base/file_replace.hpp"

namespace palp::anatomy {

namespace fs = std::filesystem;
using nlohmann::json;

const char* side_name(Side side) {
  return side == Side::left ? "left" : "right";
}

std::optional<Side> parse_side(std::string_view text) {
  if (text == "right" || text == "r") return Side::right;
  if (text == "left" || text == "l") return Side::left;
  return std::nullopt;
}

namespace {

// ------------------------------------------------------------------ writing

double rounded(double v, double step) {
  return std::round(v / step) * step;
}

json point_json(const std::optional<Vec3d>& p, double step = 0.01) {
  if (!p) return nullptr;
  return json::array({rounded(p->x, step), rounded(p->y, step), rounded(p->z, step)});
}

json text_or_null(const std::optional<std::string>& text) {
  return text ? json(*text) : json(nullptr);
}

// The members every landmark has: its confidence and, when there is one, the reason.
void add_common(json& j, double confidence, const std::string& reason) {
  j["confidence"] = rounded(confidence, 0.001);
  if (!reason.empty()) j["reason"] = reason;
}

json rib_json(const Rib& rib) {
  json points = json::array();
  for (const Vec3d& p : rib.points) points.push_back(point_json(p));
  json j{{"side", side_name(rib.side)},
         {"number", rib.number ? json(*rib.number) : json(nullptr)},
         {"points", std::move(points)}};
  add_common(j, rib.confidence, rib.reason);
  return j;
}

json space_json(const IntercostalSpace& s) {
  json j{{"side", side_name(s.side)},
         {"upper_rib", s.upper_rib ? json(*s.upper_rib) : json(nullptr)},
         {"skin_point", point_json(s.skin_point)},
         {"normal", point_json(s.normal, 0.0001)}};
  add_common(j, s.confidence, s.reason);
  return j;
}

json vertebra_json(const Vertebra& v) {
  json j{{"name", text_or_null(v.name)},
         {"body_centre", point_json(v.body_centre)},
         {"spinous_tip", point_json(v.spinous_tip)}};
  add_common(j, v.confidence, v.reason);
  return j;
}

json crest_json(const IliacCrest& c) {
  json j{{"side", side_name(c.side)}, {"top", point_json(c.top)}};
  add_common(j, c.confidence, c.reason);
  return j;
}

json tuffier_json(const TuffierLine& t) {
  json j{{"z_mm", t.z_mm ? json(rounded(*t.z_mm, 0.01)) : json(nullptr)},
         {"vertebral_level", text_or_null(t.vertebral_level)}};
  add_common(j, t.confidence, t.reason);
  return j;
}

json interspace_json(const LumbarInterspace& s) {
  json j{{"name", s.name},
         {"skin_point", point_json(s.skin_point)},
         {"normal", point_json(s.normal, 0.0001)}};
  add_common(j, s.confidence, s.reason);
  return j;
}

json femoral_json(const FemoralPulsePoint& f) {
  json j{{"side", side_name(f.side)},
         {"skin_point", point_json(f.skin_point)},
         {"normal", point_json(f.normal, 0.0001)},
         {"source", f.source.empty() ? json(nullptr) : json(f.source)}};
  add_common(j, f.confidence, f.reason);
  return j;
}

template <class T, class F>
json array_of(const std::vector<T>& items, F&& one) {
  json a = json::array();
  for (const T& item : items) a.push_back(one(item));
  return a;
}

// ------------------------------------------------------------------ reading

// Reads one value with the context for errors ("NAME: ribs[3].side: ...").
class Reader {
 public:
  explicit Reader(std::string name) : name_(std::move(name)) {}

  [[noreturn]] void fail(const std::string& where, const std::string& what) const {
    throw InputError(name_ + ": " + where + ": " + what);
  }

  const json& member(const json& object, const std::string& where, const char* key) const {
    if (!object.is_object()) fail(where, "not an object");
    const auto it = object.find(key);
    if (it == object.end()) fail(where, std::string("no member \"") + key + "\"");
    return *it;
  }

  double number(const json& j, const std::string& where) const {
    if (!j.is_number()) fail(where, "not a number");
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(where, "not finite");
    return v;
  }

  std::optional<Vec3d> point(const json& j, const std::string& where) const {
    if (j.is_null()) return std::nullopt;
    if (!j.is_array() || j.size() != 3) fail(where, "not a point [x, y, z]");
    return Vec3d{number(j[0], where), number(j[1], where), number(j[2], where)};
  }

  std::optional<std::string> text(const json& j, const std::string& where) const {
    if (j.is_null()) return std::nullopt;
    if (!j.is_string()) fail(where, "not a string");
    return j.get<std::string>();
  }

  std::optional<int> integer(const json& j, const std::string& where) const {
    if (j.is_null()) return std::nullopt;
    if (!j.is_number_integer()) fail(where, "not an integer");
    const auto v = j.get<long long>();
    if (v < -1000 || v > 1000) fail(where, "out of range");
    return static_cast<int>(v);
  }

  Side side(const json& object, const std::string& where) const {
    const std::optional<std::string> t = text(member(object, where, "side"), where + ".side");
    const std::optional<Side> s = t ? parse_side(*t) : std::nullopt;
    if (!s) fail(where + ".side", "not \"right\" or \"left\"");
    return *s;
  }

  // confidence in [0, 1] and the optional reason.
  void common(const json& object, const std::string& where, double* confidence,
              std::string* reason) const {
    *confidence = number(member(object, where, "confidence"), where + ".confidence");
    if (*confidence < 0.0 || *confidence > 1.0) fail(where + ".confidence", "outside [0, 1]");
    if (const auto it = object.find("reason"); it != object.end())
      *reason = text(*it, where + ".reason").value_or("");
  }

  const json& array(const json& root, const char* key, std::size_t max) const {
    const json& a = member(root, "landmarks", key);
    if (!a.is_array()) fail(key, "not an array");
    if (a.size() > max) fail(key, "more than " + std::to_string(max) + " entries");
    return a;
  }

 private:
  std::string name_;
};

std::string at(const char* key, std::size_t i) {
  return std::string(key) + "[" + std::to_string(i) + "]";
}

Rib read_rib(const Reader& r, const json& j, const std::string& w) {
  Rib rib;
  rib.side = r.side(j, w);
  rib.number = r.integer(r.member(j, w, "number"), w + ".number");
  const json& points = r.member(j, w, "points");
  if (!points.is_array()) r.fail(w + ".points", "not an array");
  if (points.size() > kMaxRibPoints)
    r.fail(w + ".points", "more than " + std::to_string(kMaxRibPoints) + " points");
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto p = r.point(points[i], at("points", i));
    if (!p) r.fail(w + "." + at("points", i), "null");
    rib.points.push_back(*p);
  }
  r.common(j, w, &rib.confidence, &rib.reason);
  return rib;
}

IntercostalSpace read_space(const Reader& r, const json& j, const std::string& w) {
  IntercostalSpace s;
  s.side = r.side(j, w);
  s.upper_rib = r.integer(r.member(j, w, "upper_rib"), w + ".upper_rib");
  s.skin_point = r.point(r.member(j, w, "skin_point"), w + ".skin_point");
  s.normal = r.point(r.member(j, w, "normal"), w + ".normal");
  r.common(j, w, &s.confidence, &s.reason);
  return s;
}

Vertebra read_vertebra(const Reader& r, const json& j, const std::string& w) {
  Vertebra v;
  v.name = r.text(r.member(j, w, "name"), w + ".name");
  const auto centre = r.point(r.member(j, w, "body_centre"), w + ".body_centre");
  if (!centre) r.fail(w + ".body_centre", "null");
  v.body_centre = *centre;
  v.spinous_tip = r.point(r.member(j, w, "spinous_tip"), w + ".spinous_tip");
  r.common(j, w, &v.confidence, &v.reason);
  return v;
}

IliacCrest read_crest(const Reader& r, const json& j, const std::string& w) {
  IliacCrest c;
  c.side = r.side(j, w);
  c.top = r.point(r.member(j, w, "top"), w + ".top");
  r.common(j, w, &c.confidence, &c.reason);
  return c;
}

TuffierLine read_tuffier(const Reader& r, const json& j) {
  const std::string w = "tuffier_line";
  TuffierLine t;
  const json& z = r.member(j, w, "z_mm");
  if (!z.is_null()) t.z_mm = r.number(z, w + ".z_mm");
  t.vertebral_level = r.text(r.member(j, w, "vertebral_level"), w + ".vertebral_level");
  r.common(j, w, &t.confidence, &t.reason);
  return t;
}

LumbarInterspace read_interspace(const Reader& r, const json& j, const std::string& w) {
  LumbarInterspace s;
  const auto name = r.text(r.member(j, w, "name"), w + ".name");
  if (!name) r.fail(w + ".name", "null");
  s.name = *name;
  s.skin_point = r.point(r.member(j, w, "skin_point"), w + ".skin_point");
  s.normal = r.point(r.member(j, w, "normal"), w + ".normal");
  r.common(j, w, &s.confidence, &s.reason);
  return s;
}

FemoralPulsePoint read_femoral(const Reader& r, const json& j, const std::string& w) {
  FemoralPulsePoint f;
  f.side = r.side(j, w);
  f.skin_point = r.point(r.member(j, w, "skin_point"), w + ".skin_point");
  f.normal = r.point(r.member(j, w, "normal"), w + ".normal");
  f.source = r.text(r.member(j, w, "source"), w + ".source").value_or("");
  r.common(j, w, &f.confidence, &f.reason);
  return f;
}

template <class T, class F>
std::vector<T> read_array(const Reader& r, const json& root, const char* key, F&& one) {
  const json& a = r.array(root, key, kMaxLandmarkItems);
  std::vector<T> items;
  items.reserve(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) items.push_back(one(r, a[i], at(key, i)));
  return items;
}

}  // namespace

std::string landmarks_to_json(const Landmarks& l) {
  json root;
  root["format"] = "palp-landmarks-1";
  root["frame"] = "LPS";
  root["units"] = "mm";
  root["scene"] = l.scene;
  root["notes"] = l.notes;
  root["ribs"] = array_of(l.ribs, rib_json);
  root["intercostal_spaces"] = array_of(l.intercostal_spaces, space_json);
  root["vertebrae"] = array_of(l.vertebrae, vertebra_json);
  root["iliac_crests"] = array_of(l.iliac_crests, crest_json);
  root["tuffier_line"] = tuffier_json(l.tuffier_line);
  root["lumbar_interspaces"] = array_of(l.lumbar_interspaces, interspace_json);
  root["femoral_pulse_points"] = array_of(l.femoral_pulse_points, femoral_json);
  return root.dump(2) + "\n";
}

Landmarks landmarks_from_json(std::string_view text, const std::string& name) {
  const json root = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  const Reader r(name);
  if (root.is_discarded() || !root.is_object()) r.fail("landmarks", "not a JSON object");
  Landmarks l;
  if (const auto it = root.find("scene"); it != root.end())
    l.scene = r.text(*it, "scene").value_or("");
  if (const auto it = root.find("notes"); it != root.end()) {
    if (!it->is_array() || it->size() > kMaxLandmarkItems) r.fail("notes", "not a short array");
    for (std::size_t i = 0; i < it->size(); ++i)
      l.notes.push_back(r.text((*it)[i], at("notes", i)).value_or(""));
  }
  l.ribs = read_array<Rib>(r, root, "ribs", read_rib);
  l.intercostal_spaces = read_array<IntercostalSpace>(r, root, "intercostal_spaces", read_space);
  l.vertebrae = read_array<Vertebra>(r, root, "vertebrae", read_vertebra);
  l.iliac_crests = read_array<IliacCrest>(r, root, "iliac_crests", read_crest);
  l.tuffier_line = read_tuffier(r, r.member(root, "landmarks", "tuffier_line"));
  l.lumbar_interspaces =
      read_array<LumbarInterspace>(r, root, "lumbar_interspaces", read_interspace);
  l.femoral_pulse_points =
      read_array<FemoralPulsePoint>(r, root, "femoral_pulse_points", read_femoral);
  return l;
}

void write_landmarks(const std::string& path, const Landmarks& landmarks) {
  replace_file(path, landmarks_to_json(landmarks));
}

Landmarks read_landmarks(const std::string& path) {
  std::error_code ec;
  const std::uintmax_t bytes = fs::file_size(path, ec);
  if (ec) throw InputError(path + ": cannot be read: " + ec.message());
  if (bytes > kMaxLandmarksFileBytes)
    throw InputError(path + ": " + std::to_string(bytes) + " bytes, more than the " +
                     std::to_string(kMaxLandmarksFileBytes >> 20) + " MiB a landmarks file may have");
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in && !in.eof()) throw InputError(path + ": cannot be read");
  return landmarks_from_json(text.str(), path);
}

const IntercostalSpace* find_intercostal_space(const Landmarks& l, Side side, int upper_rib) {
  for (const IntercostalSpace& s : l.intercostal_spaces)
    if (s.side == side && s.upper_rib == upper_rib) return &s;
  return nullptr;
}

const LumbarInterspace* find_lumbar_interspace(const Landmarks& l, std::string_view name) {
  for (const LumbarInterspace& s : l.lumbar_interspaces)
    if (s.name == name) return &s;
  return nullptr;
}

const FemoralPulsePoint* find_femoral_pulse_point(const Landmarks& l, Side side) {
  for (const FemoralPulsePoint& f : l.femoral_pulse_points)
    if (f.side == side) return &f;
  return nullptr;
}

const Rib* find_rib(const Landmarks& l, Side side, int number) {
  for (const Rib& rib : l.ribs)
    if (rib.side == side && rib.number == number) return &rib;
  return nullptr;
}

const Vertebra* find_vertebra(const Landmarks& l, std::string_view name) {
  for (const Vertebra& v : l.vertebrae)
    if (v.name && *v.name == name) return &v;
  return nullptr;
}

}  // namespace palp::anatomy
