// The ribs' numbers and the intercostal spaces (ribs.hpp): a rib whose head is in the scan takes
// the number of the thoracic vertebra its head lies at; one whose head is outside it (the scan's
// edge cuts it) takes its order among numbered ribs of its side at an angle they share; the
// spaces lie on the skin at the mid-axillary line midway between consecutive ribs.
#include <algorithm>
#include <cstdio>
#include <cmath>
#include <map>
#include <optional>
#include <string>

#include "anatomy/ribs.hpp"
#include "anatomy/skeleton_labels.hpp"

namespace palp::anatomy {
namespace {

struct Numbered {
  const RibTrace* trace = nullptr;
  Rib rib;
  double angle_lo = 0.0, angle_hi = 0.0;  // the line's range of angles behind the MAL
};

// Where the line first crosses `angle` (degrees behind the MAL) going outward: index point.
std::optional<Vec3d> crossing(const ScanContext& scan, const std::vector<Vec3d>& line,
                              double angle) {
  for (std::size_t i = 0; i + 1 < line.size(); ++i) {
    const double a = angle_behind_mal(scan, line[i]) - angle;
    const double b = angle_behind_mal(scan, line[i + 1]) - angle;
    if (a == 0.0) return line[i];
    if ((a > 0.0) != (b > 0.0)) {
      const double t = a / (a - b);
      return line[i] + (line[i + 1] - line[i]) * t;
    }
  }
  return std::nullopt;
}

std::string join(const std::string& a, const std::string& b) {
  return a.empty() || a == b ? b : b.empty() ? a : a + "; " + b;
}

// The number of a rib whose head is in the scan, from its vertebra's name.
void number_by_head(const Spine& spine, const RibTrace& t, Rib& rib) {
  if (t.vertebra < 0) {
    rib.reason = "its head lies beyond the vertebrae found along the column";
    rib.confidence *= 0.5;
    return;
  }
  const VertebraSegment& seg = spine.segments[static_cast<std::size_t>(t.vertebra)];
  if (!seg.name) {
    rib.reason = "its vertebra is not numbered: " + seg.reason;
    rib.confidence *= 0.5;
    return;
  }
  const std::string& name = *seg.name;
  if (name[0] == 'T') {
    rib.number = std::stoi(name.substr(1));
    rib.confidence = std::min(rib.confidence, seg.confidence);
    rib.reason = seg.reason;
    return;
  }
  rib.confidence = std::min(rib.confidence, seg.confidence) * 0.5;
  rib.reason = "it articulates with the vertebra counted " + name +
               " from the sacrum: a " + (name[0] == 'L' ? "lumbar" : "cervical") +
               " rib, or a transitional vertebra (the count then is one off)";
}

// Two ribs are compared where both run over at least this many degrees about the body's centre
// (8 mm of a 150 mm radius: two centre line samples).
constexpr double kMinSharedDeg = 3.0;

// Numbers headless ribs by their order at an angle shared with a numbered rib of their side:
// the ribs of a side run roughly parallel, so at one angle behind the MAL they stack in order,
// the lower the higher-numbered. Repeats while a rib gains a number.
void number_by_order(const ScanContext& scan, std::vector<Numbered>& ribs) {
  for (bool changed = true; changed;) {
    changed = false;
    for (Numbered& u : ribs) {
      if (u.rib.number || u.trace->head_in_scan) continue;
      const Numbered* best = nullptr;
      double best_overlap = 0.0;
      for (const Numbered& r : ribs) {
        if (!r.rib.number || r.trace->side != u.trace->side) continue;
        const double overlap =
            std::min(u.angle_hi, r.angle_hi) - std::max(u.angle_lo, r.angle_lo);
        if (overlap > best_overlap) best = &r, best_overlap = overlap;
      }
      if (!best || best_overlap < kMinSharedDeg) continue;
      const double angle = 0.5 * (std::max(u.angle_lo, best->angle_lo) +
                                  std::min(u.angle_hi, best->angle_hi));
      const auto zu = crossing(scan, u.trace->line, angle);
      const auto zr = crossing(scan, best->trace->line, angle);
      if (!zu || !zr) continue;
      int between = 0;
      for (const Numbered& o : ribs) {
        if (&o == &u || &o == best || o.trace->side != u.trace->side) continue;
        const auto zo = crossing(scan, o.trace->line, angle);
        if (zo && zo->z > std::min(zu->z, zr->z) && zo->z < std::max(zu->z, zr->z)) ++between;
      }
      const int step = between + 1;
      const int number = *best->rib.number + (zu->z < zr->z ? step : -step);
      if (number < 1 || number > 12) continue;
      u.rib.number = number;
      u.rib.confidence = std::min(u.rib.confidence, best->rib.confidence) * 0.8;
      char where[96];
      std::snprintf(where, sizeof where, "%.0f degrees behind the mid-axillary line",
                    angle);
      u.rib.reason = "its head is outside the scan: numbered by its order " +
                     std::string(zu->z < zr->z ? "below" : "above") + " rib " +
                     std::to_string(*best->rib.number) + " at " + where;
      changed = true;
    }
  }
}

// The space below rib `upper` on a side.
IntercostalSpace space_between(const ScanContext& scan, const std::vector<Numbered>& ribs,
                               int side, int upper) {
  IntercostalSpace s;
  s.side = side_of(side);
  s.upper_rib = upper;
  const Numbered* pair[2] = {nullptr, nullptr};
  for (const Numbered& r : ribs)
    for (int k = 0; k < 2; ++k)
      if (r.trace->side == side && r.rib.number == upper + k &&
          (!pair[k] || r.trace->line.size() > pair[k]->trace->line.size()))
        pair[k] = &r;
  Vec3d at[2];
  for (int k = 0; k < 2; ++k) {
    const std::string name = "rib " + std::to_string(upper + k);
    if (!pair[k]) {
      s.reason = name + " is not found on this side";
      return s;
    }
    const auto c = crossing(scan, pair[k]->trace->line, 0.0);
    if (!c) {
      char text[160];
      if (pair[k]->angle_lo > 0.0)
        std::snprintf(text, sizeof text, "%s ends %.0f degrees behind the mid-axillary line",
                      name.c_str(), pair[k]->angle_lo);
      else
        std::snprintf(text, sizeof text,
                      "%s is in the scan only in front of the mid-axillary line (the scan's edge "
                      "cuts it behind)",
                      name.c_str());
      s.reason = text;
      return s;
    }
    at[k] = *c;
  }
  // Midway between the two crossings, on the MAL's coronal plane, then laterally to the skin.
  Vec3d mid = (at[0] + at[1]) * 0.5;
  const auto k = static_cast<std::size_t>(
      std::clamp<std::int64_t>(std::lround(mid.z), 0, scan.bone.dims[2] - 1));
  mid.y = scan.bodies[k].cy;
  const Vec3d world = scan.bone.world(mid);
  const Vec3d lateral = scan.bone.world(mid + Vec3d{side == 0 ? -1.0 : 1.0, 0.0, 0.0}) - world;
  const auto skin = skin_along(scan, world, lateral * (1.0 / norm(lateral)));
  if (!skin) {
    s.reason = "no skin lateral of the ribs in the scan";
    return s;
  }
  s.skin_point = skin->point;
  s.normal = skin->normal;
  s.confidence = std::min(pair[0]->rib.confidence, pair[1]->rib.confidence);
  s.reason = join(pair[0]->rib.reason, pair[1]->rib.reason);
  return s;
}

// A labelled rib's number and side (skeleton_labels.hpp), over what its head's vertebra said.
void apply_rib_label(const RibTrace& t, Rib& rib, std::vector<std::string>& notes) {
  const Side side = side_of(t.label_side);
  const bool differs = (rib.number && *rib.number != t.label_number) || rib.side != side;
  if (differs) {
    const std::string counted =
        rib.number ? "rib " + std::to_string(*rib.number) + " " + side_name(rib.side)
                   : std::string("unnumbered");
    rib.reason = "numbered by the label map (" + t.label_name + "); its head's vertebra says " +
                 counted;
    notes.push_back("The label map names " + t.label_name + " the rib counted " + counted +
                    ": the label map's number is used.");
  } else {
    rib.reason.clear();
  }
  rib.number = t.label_number;
  rib.side = side;
  rib.confidence = differs ? kLabelDisagreesConfidence : kLabelledConfidence;
}

}  // namespace

void rib_landmarks(const ScanContext& scan, const Spine& spine, const std::vector<RibTrace>& traces,
                   Landmarks& out) {
  std::vector<Numbered> ribs;
  for (const RibTrace& t : traces) {
    Numbered n;
    n.trace = &t;
    n.rib.side = side_of(t.side);
    for (const Vec3d& p : t.line) n.rib.points.push_back(scan.bone.world(p));
    n.rib.confidence = t.confidence;
    n.angle_lo = 1e9, n.angle_hi = -1e9;
    for (const Vec3d& p : t.line) {
      const double a = angle_behind_mal(scan, p);
      n.angle_lo = std::min(n.angle_lo, a), n.angle_hi = std::max(n.angle_hi, a);
    }
    if (t.head_in_scan) number_by_head(spine, t, n.rib);
    if (t.label_number > 0) apply_rib_label(t, n.rib, out.notes);
    ribs.push_back(std::move(n));
  }
  number_by_order(scan, ribs);
  for (Numbered& n : ribs)
    if (!n.rib.number && !n.trace->head_in_scan && n.rib.reason.empty())
      n.rib.reason = "its head is outside the scan and no numbered rib of its side shares its "
                     "angles to count from";
  std::stable_sort(ribs.begin(), ribs.end(), [](const Numbered& a, const Numbered& b) {
    if (a.trace->side != b.trace->side) return a.trace->side < b.trace->side;
    return a.rib.number.value_or(99) < b.rib.number.value_or(99);
  });
  std::map<int, std::pair<int, int>> range;  // side -> lowest and highest number
  for (const Numbered& n : ribs) {
    out.ribs.push_back(n.rib);
    if (!n.rib.number) continue;
    auto [it, fresh] = range.try_emplace(n.trace->side, *n.rib.number, *n.rib.number);
    if (!fresh)
      it->second = {std::min(it->second.first, *n.rib.number),
                    std::max(it->second.second, *n.rib.number)};
  }
  for (const auto& [side, r] : range)
    for (int upper = r.first; upper < r.second; ++upper)
      out.intercostal_spaces.push_back(space_between(scan, ribs, side, upper));
  if (traces.empty())
    out.notes.push_back("No ribs found: no rod-shaped bone beside the column under the body wall.");
}

}  // namespace palp::anatomy
