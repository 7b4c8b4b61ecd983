// Finding the ribs (ribs.hpp): bone pieces beyond the column's band, each piece's centre line as
// the centroids of its geodesic level sets from its head end, kept when rod-shaped, long and
// under the body wall.
#include "anatomy/ribs.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <queue>

namespace palp::anatomy {
namespace {

Vec3d as_vec(const Index3& p) {
  return {static_cast<double>(p[0]), static_cast<double>(p[1]), static_cast<double>(p[2])};
}

// mm between two index points.
double mm_between(const PatientMask& m, const Vec3d& a, const Vec3d& b) {
  const Vec3d d{(a.x - b.x) * m.spacing[0], (a.y - b.y) * m.spacing[1], (a.z - b.z) * m.spacing[2]};
  return norm(d);
}

// The column's centre (index x, y) at slice z: the anterior column where the scan shows it, else
// the midline and the body's centre.
Vec3d column_at(const ScanContext& scan, const Spine& spine, std::int64_t z) {
  const auto k = static_cast<std::size_t>(std::clamp<std::int64_t>(z, 0, scan.bone.dims[2] - 1));
  if (k < spine.column.size() && spine.column[k].on_column)
    return {spine.column[k].x, spine.column[k].y, static_cast<double>(z)};
  const double y = scan.bodies[k].voxels ? scan.bodies[k].cy : 0.5 * scan.bone.dims[1];
  return {scan.midline_x, y, static_cast<double>(z)};
}

// A piece's voxels as a graph (26-neighbours, mm edge lengths) for geodesic distances.
class PieceGraph {
 public:
  PieceGraph(const PatientMask& m, const Piece& p) : m_(m), voxels_(p.voxels) {
    std::sort(voxels_.begin(), voxels_.end());
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (dx || dy || dz)
            steps_.push_back({{dx, dy, dz},
                              std::hypot(dx * m.spacing[0], dy * m.spacing[1], dz * m.spacing[2])});
  }
  std::size_t size() const { return voxels_.size(); }
  Vec3d point(std::size_t i) const { return as_vec(index3(m_, voxels_[i])); }

  // Geodesic distances (mm) from `sources`; `parent` the previous voxel on a shortest path.
  std::vector<double> distances(const std::vector<std::size_t>& sources,
                                std::vector<std::size_t>* parent = nullptr) const {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    std::vector<double> d(size(), kInf);
    if (parent) parent->assign(size(), size());
    using Item = std::pair<double, std::size_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
    for (std::size_t s : sources) d[s] = 0.0, queue.push({0.0, s});
    while (!queue.empty()) {
      const auto [dist, i] = queue.top();
      queue.pop();
      if (dist > d[i]) continue;
      const Index3 p = index3(m_, voxels_[i]);
      for (const Step& s : steps_) {
        const Index3 q{p[0] + s.d[0], p[1] + s.d[1], p[2] + s.d[2]};
        if (!m_.contains(q[0], q[1], q[2])) continue;
        const auto it = std::lower_bound(voxels_.begin(), voxels_.end(), m_.linear(q[0], q[1], q[2]));
        if (it == voxels_.end() || *it != m_.linear(q[0], q[1], q[2])) continue;
        const auto j = static_cast<std::size_t>(it - voxels_.begin());
        if (dist + s.mm < d[j]) {
          d[j] = dist + s.mm;
          if (parent) (*parent)[j] = i;
          queue.push({d[j], j});
        }
      }
    }
    return d;
  }

 private:
  struct Step {
    std::array<std::int64_t, 3> d;
    double mm;
  };
  const PatientMask& m_;
  std::vector<std::size_t> voxels_;
  std::vector<Step> steps_;
};

std::size_t farthest(const std::vector<double>& d) {
  std::size_t best = 0;
  for (std::size_t i = 0; i < d.size(); ++i)
    if (std::isfinite(d[i]) && d[i] > d[best]) best = i;
  return best;
}

// The centre line from `head` (a voxel of the graph at one end, `tip_end` the other) to the
// geodesically farthest voxel: every
// kRibStepMm of geodesic distance, the centroid of the voxels within half a step of that
// distance and within kRibMaxWidthMm of the shortest path's voxel there (a side branch's voxels
// at the same distance lie farther off). Sets the trace's length.
void centre_line(const PatientMask& m, const PieceGraph& g, std::size_t head, std::size_t tip_end,
                 RibTrace& rib) {
  // Sources: the head's whole end face (a cut across the rod at the column's band or the scan's
  // edge, not only its corner voxel nearest the column): the voxels geodesically farthest from
  // the other end, within one voxel's diagonal of the farthest.
  const std::vector<double> from_tip = g.distances({tip_end});
  const double reach = from_tip[head] - std::max(3.0, 1.5 * std::max({m.spacing[0], m.spacing[1],
                                                                       m.spacing[2]}));
  std::vector<std::size_t> cap;
  for (std::size_t i = 0; i < g.size(); ++i)
    if (std::isfinite(from_tip[i]) && from_tip[i] >= reach) cap.push_back(i);
  std::vector<std::size_t> parent;
  const std::vector<double> d = g.distances(cap, &parent);
  const std::size_t tip = farthest(d);
  rib.length_mm = d[tip] + 0.5 * kRibStepMm;
  std::vector<std::size_t> path;  // tip back to the cap
  for (std::size_t i = tip; i < g.size(); i = parent[i]) path.push_back(i);
  const auto samples = static_cast<int>(std::floor(d[tip] / kRibStepMm)) + 1;
  for (int s = 0; s <= samples; ++s) {
    const double at = std::min(d[tip], s * kRibStepMm);
    std::size_t on_path = path.back();
    for (std::size_t i : path)
      if (std::fabs(d[i] - at) < std::fabs(d[on_path] - at)) on_path = i;
    Vec3d sum{};
    double n = 0.0;
    for (std::size_t i = 0; i < g.size(); ++i)
      if (std::fabs(d[i] - at) <= 0.5 * kRibStepMm &&
          mm_between(m, g.point(i), g.point(on_path)) <= kRibMaxWidthMm)
        sum += g.point(i), n += 1.0;
    if (n > 0.0) rib.line.push_back(sum * (1.0 / n));
    if (at >= d[tip]) break;
  }
}

// The fraction of the centre line within kRibMaxDepthMm of the skin.
double superficial_fraction(const ScanContext& scan, const std::vector<Vec3d>& line) {
  if (line.empty()) return 0.0;
  double n = 0.0;
  for (const Vec3d& p : line)
    if (scan.skin.distance(scan.bone.world(p)) <= kRibMaxDepthMm) n += 1.0;
  return n / static_cast<double>(line.size());
}

// The trace of one piece, or nothing when it is not rib-shaped.
std::optional<RibTrace> trace_piece(const ScanContext& scan, const Spine& spine, const Piece& p) {
  const PatientMask& m = scan.bone;
  const PieceGraph g(m, p);
  // The piece's two ends: the farthest voxel from any, and the farthest from that.
  const std::size_t a = farthest(g.distances({0}));
  const std::size_t b = farthest(g.distances({a}));
  const auto from_column = [&](std::size_t i) {
    const Vec3d q = g.point(i);
    const Vec3d c = column_at(scan, spine, std::lround(q.z));
    return std::hypot((q.x - c.x) * m.spacing[0], (q.y - c.y) * m.spacing[1]);
  };
  // The head end: the end nearest the column when it reaches the column's band, else (a piece
  // the scan's edge cuts off its head) the end farther behind the mid-axillary line.
  const double near = std::min(from_column(a), from_column(b));
  std::size_t head = from_column(a) <= from_column(b) ? a : b;
  if (near > kColumnHalfWidthMm + kHeadReachMm)
    head = angle_behind_mal(scan, g.point(a)) >= angle_behind_mal(scan, g.point(b)) ? a : b;
  RibTrace rib;
  const Vec3d column = column_at(scan, spine, std::lround(p.centroid.z));
  rib.side = p.centroid.x < column.x ? 0 : 1;
  rib.head = g.point(head);
  centre_line(m, g, head, head == a ? b : a, rib);
  const double volume = static_cast<double>(p.voxels.size()) * m.spacing[0] * m.spacing[1] *
                        m.spacing[2];
  rib.width_mm = 2.0 * std::sqrt(volume / (3.14159265358979 * std::max(rib.length_mm, 1.0)));
  if (rib.length_mm < kRibMinLengthMm || rib.width_mm < kRibMinWidthMm ||
      rib.width_mm > kRibMaxWidthMm || rib.line.size() < 2)
    return std::nullopt;
  if (superficial_fraction(scan, rib.line) < 0.5) return std::nullopt;
  // The head end against the column's band and behind the body's centre (the necks run back to
  // the transverse processes), or the piece cut by the scan's upper or lower edge.
  const Vec3d c = column_at(scan, spine, std::lround(rib.head.z));
  const double reach = std::fabs(rib.head.x - c.x) * m.spacing[0];
  const SliceBody& body = scan.bodies[static_cast<std::size_t>(std::lround(rib.head.z))];
  rib.head_in_scan = reach <= kColumnHalfWidthMm + kHeadReachMm && rib.head.y > body.cy;
  if (!rib.head_in_scan && p.lo[2] > 0 && p.hi[2] < m.dims[2] - 1) return std::nullopt;
  // Shape confidence: 1 for a rib's usual 8-15 mm, falling to 0.5 at the band's ends.
  const double w = rib.width_mm;
  rib.confidence = w < 8.0 ? 0.5 + 0.5 * (w - kRibMinWidthMm) / (8.0 - kRibMinWidthMm)
                   : w > 15.0 ? 0.5 + 0.5 * (kRibMaxWidthMm - w) / (kRibMaxWidthMm - 15.0)
                              : 1.0;
  return rib;
}

// The segment a head at index z articulates with: the head of ribs 2-9 spans the disc above its
// own vertebra (it meets both bodies, mostly its own), of ribs 10-12 its own body's upper half,
// and the neck runs to the transverse process of its own vertebra: a quarter of a vertebra below
// the head end lies in the rib's own vertebra either way.
// A head end a little beyond the column's found ends (the top vertebra's segment ends at its
// upper endplate, the head of its rib reaches the disc above) still counts within a quarter.
int head_segment(const Spine& spine, double z) {
  if (spine.segments.empty()) return -1;
  const auto height = [](const VertebraSegment& s) { return s.z_hi - s.z_lo; };
  int at = segment_at(spine, z);
  const VertebraSegment& top = spine.segments.back();
  if (at < 0 && z >= top.z_hi && z < top.z_hi + 0.25 * height(top))
    at = static_cast<int>(spine.segments.size()) - 1;
  if (at < 0) return -1;
  const VertebraSegment& s = spine.segments[static_cast<std::size_t>(at)];
  const int below = segment_at(spine, z - 0.25 * height(s));
  return below >= 0 ? below : (z - 0.25 * height(s) >= s.z_lo ? at : -1);
}

}  // namespace

std::vector<RibTrace> find_ribs(const ScanContext& scan, const Spine& spine) {
  const PatientMask& m = scan.bone;
  std::vector<RibTrace> out;
  if (m.data.empty()) return out;
  std::vector<double> column_x(static_cast<std::size_t>(m.dims[2]));
  for (std::int64_t z = 0; z < m.dims[2]; ++z)
    column_x[static_cast<std::size_t>(z)] = column_at(scan, spine, z).x;
  const double band = kColumnHalfWidthMm / m.spacing[0];
  const double min_ml = kRibMinLengthMm * 3.14159265358979 * 0.25 * kRibMinWidthMm *
                        kRibMinWidthMm;  // mm^3
  const auto min_voxels = static_cast<std::size_t>(
      std::max(1.0, min_ml / (m.spacing[0] * m.spacing[1] * m.spacing[2])));
  const auto pieces = pieces_of(
      m,
      [&](std::int64_t x, std::int64_t, std::int64_t z) {
        return std::fabs(static_cast<double>(x) - column_x[static_cast<std::size_t>(z)]) > band;
      },
      min_voxels);
  // A piece far larger than a whole rib (a hip bone, a femur, a scapula) is not one.
  const double max_ml = 2.0 * 400.0 * 3.14159265358979 * 0.25 * kRibMaxWidthMm * kRibMaxWidthMm;
  for (const Piece& p : pieces) {
    if (static_cast<double>(p.voxels.size()) * m.spacing[0] * m.spacing[1] * m.spacing[2] >
        max_ml)
      continue;
    auto rib = trace_piece(scan, spine, p);
    if (!rib) continue;
    if (rib->head_in_scan) rib->vertebra = head_segment(spine, rib->head.z);
    out.push_back(std::move(*rib));
  }
  return out;
}

double angle_behind_mal(const ScanContext& scan, const Vec3d& p) {
  const auto k = static_cast<std::size_t>(
      std::clamp<std::int64_t>(std::lround(p.z), 0, scan.bone.dims[2] - 1));
  const SliceBody& b = scan.bodies[k];
  const double lateral = std::fabs(p.x - b.cx) * scan.bone.spacing[0];
  const double behind = (p.y - b.cy) * scan.bone.spacing[1];
  return std::atan2(behind, lateral) * 180.0 / 3.14159265358979;
}

}  // namespace palp::anatomy
