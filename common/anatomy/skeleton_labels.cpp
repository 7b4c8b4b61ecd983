// Names from the labelled vertebrae and ribs (skeleton_labels.hpp).
#include "anatomy/skeleton_labels.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>

namespace palp::anatomy {
namespace {

// Across (x) and in front of the body's centre (y), the box a vertebra's labels are read in (mm).
constexpr double kAcrossMm = 25.0, kFrontMm = 30.0;

struct Tally {
  std::map<std::uint8_t, double> count;
  std::map<std::uint8_t, Vec3d> sum;
  double total = 0.0;
  // The value most voxels hold, or 0; `share` its share of the labelled voxels.
  std::uint8_t winner(double& share) const {
    std::uint8_t best = 0;
    double most = 0.0;
    for (const auto& [v, n] : count)
      if (n > most) most = n, best = v;
    share = total > 0.0 ? most / total : 0.0;
    return best;
  }
};

const std::string& name_of(const ScanContext& scan, std::uint8_t value) {
  static const std::string none;
  return value >= 1 && value <= scan.skeleton_names.size() ? scan.skeleton_names[value - 1u] : none;
}

// The vertebra labels over a segment's body.
Tally vertebra_tally(const ScanContext& scan, const Spine& spine, const VertebraSegment& seg) {
  const PatientMask& m = *scan.skeleton;
  Tally t;
  const auto x0 = std::lround(seg.centre.x - kAcrossMm / m.spacing[0]);
  const auto x1 = std::lround(seg.centre.x + kAcrossMm / m.spacing[0]);
  const auto y0 = std::lround(seg.centre.y - kFrontMm / m.spacing[1]);
  const auto z0 = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::ceil(seg.z_lo)));
  const auto z1 = std::min<std::int64_t>(m.dims[2] - 1, static_cast<std::int64_t>(seg.z_hi));
  for (std::int64_t z = z0; z <= z1; ++z) {
    const ColumnSlice& c = spine.column[static_cast<std::size_t>(z)];
    const auto wall = std::lround(c.y + 0.5 * c.depth);  // the body's posterior wall
    for (std::int64_t y = std::max<std::int64_t>(0, y0); y <= std::min(wall, m.dims[1] - 1); ++y)
      for (std::int64_t x = std::max<std::int64_t>(0, x0); x <= std::min(x1, m.dims[0] - 1); ++x) {
        const std::uint8_t v = m.data[m.linear(x, y, z)];
        if (v == 0 || vertebra_of_label(name_of(scan, v)).empty()) continue;
        t.count[v] += 1.0, t.total += 1.0;
        t.sum[v] = t.sum[v] +
                   Vec3d{static_cast<double>(x), static_cast<double>(y), static_cast<double>(z)};
      }
  }
  return t;
}

}  // namespace

std::string vertebra_of_label(const std::string& name) {
  if (name == "sacrum" || name == "vertebrae_S1") return "S";
  const std::string prefix = "vertebrae_";
  if (name.rfind(prefix, 0) == 0 && name.size() > prefix.size()) return name.substr(prefix.size());
  return "";
}

bool parse_rib_label(const std::string& name, int& side, int& number) {
  for (int s = 0; s < 2; ++s) {
    const std::string prefix = s == 0 ? "rib_right_" : "rib_left_";
    if (name.rfind(prefix, 0) != 0 || name.size() == prefix.size()) continue;
    const std::string digits = name.substr(prefix.size());
    if (digits.size() > 2 || !std::all_of(digits.begin(), digits.end(),
                                          [](unsigned char c) { return std::isdigit(c) != 0; }))
      return false;
    side = s, number = std::stoi(digits);
    return number >= 1 && number <= 12;
  }
  return false;
}

void label_vertebrae(const ScanContext& scan, Spine& spine) {
  if (!scan.skeleton) return;
  const char* count_from =
      spine.sacrum >= 0 ? "the count from the sacrum" : "the count from the lowest rib (T12)";
  for (VertebraSegment& seg : spine.segments) {
    const Tally t = vertebra_tally(scan, spine, seg);
    double share = 0.0;
    const std::uint8_t v = t.winner(share);
    if (v == 0) continue;
    const std::string label = name_of(scan, v);
    const std::string name = vertebra_of_label(label);
    // A vertebra's body centre: its label's centroid in front of the posterior wall. The sacrum's
    // label is the whole bone (alae, crest): its body keeps the column's own centre.
    if (name != "S") seg.centre = t.sum.at(v) * (1.0 / t.count.at(v));
    if (seg.name && *seg.name != name) {
      seg.reason = "named by the label map (" + label + "); " + count_from + " says " + *seg.name;
      seg.confidence = kLabelDisagreesConfidence;
      spine.notes.push_back("The label map names " + name + " the vertebra " + count_from +
                            " makes " + *seg.name +
                            ": the label map's name is used (a transitional vertebra, a missed "
                            "disc, or a mislabel).");
    } else {
      seg.reason.clear();
      seg.confidence = kLabelledConfidence;
    }
    if (share < 0.8) seg.confidence *= share;  // the body holds other vertebrae's labels too
    seg.name = name;
  }
}

void label_ribs(const ScanContext& scan, std::vector<RibTrace>& ribs) {
  if (!scan.skeleton) return;
  const PatientMask& m = *scan.skeleton;
  for (RibTrace& r : ribs) {
    Tally t;
    for (const Vec3d& p : r.line)
      for (std::int64_t dz = -2; dz <= 2; ++dz)
        for (std::int64_t dy = -2; dy <= 2; ++dy)
          for (std::int64_t dx = -2; dx <= 2; ++dx) {
            const std::int64_t x = std::lround(p.x) + dx, y = std::lround(p.y) + dy,
                               z = std::lround(p.z) + dz;
            if (x < 0 || y < 0 || z < 0 || x >= m.dims[0] || y >= m.dims[1] || z >= m.dims[2])
              continue;
            const std::uint8_t v = m.data[m.linear(x, y, z)];
            int side = 0, number = 0;
            if (v != 0 && parse_rib_label(name_of(scan, v), side, number))
              t.count[v] += 1.0, t.total += 1.0;
          }
    double share = 0.0;
    const std::uint8_t v = t.winner(share);
    if (v == 0) continue;
    r.label_name = name_of(scan, v);
    parse_rib_label(r.label_name, r.label_side, r.label_number);
  }
}

}  // namespace palp::anatomy
