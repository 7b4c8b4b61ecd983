// The trunk phantom's truth (phantom_trunk.hpp): its landmarks from the geometry it is drawn from
// (phantom_trunk_anatomy.hpp), carried into the LPS world of the drawn grid.
#include <string>

#include "io/phantom_trunk.hpp"
#include "io/phantom_trunk_anatomy.hpp"

namespace palp {
namespace {

using namespace phantom_detail;
using namespace phantom_detail::trunk;

TrunkSide side_of(int side) {
  return side < 0 ? TrunkSide::right : TrunkSide::left;
}

// Anatomy frame -> LPS world of the trunk's own (LPS, identity direction) grid.
struct WorldMap {
  Grid grid;
  AnatomyFrame frame;
  Vec3d scene(const Vec3d& p) const {
    return {p.x * frame.scale + frame.centre[0], p.y * frame.scale + frame.centre[1],
            p.z * frame.scale + frame.centre[2]};
  }
  Vec3d world(const Vec3d& p) const {
    const Vec3d s = scene(p);
    return {s.x + grid.world.origin[0], s.y + grid.world.origin[1], s.z + grid.world.origin[2]};
  }
  // Inside the volume: within half a voxel of the outermost voxel centres.
  bool inside(const Vec3d& p) const {
    const Vec3d s = scene(p);
    const double c[3] = {s.x, s.y, s.z};
    for (int a = 0; a < 3; ++a) {
      const double half = grid.spacing[a] / 2.0;
      const double last = static_cast<double>(grid.dims[a] - 1) * grid.spacing[a];
      if (c[a] < -half || c[a] > last + half) return false;
    }
    return true;
  }
};

void add_vertebrae(const WorldMap& map, TrunkTruth& t) {
  const PelvisGeometry& p = pelvis();
  const Vec3d axis = p.sacrum_body.b - p.sacrum_body.a;
  const Vec3d s1 = p.sacrum_body.a + axis * (14.0 / norm(axis));
  if (map.inside(s1)) {
    t.vertebrae.push_back({"S", map.world(s1), std::nullopt, map.world(p.sacrum_body.b).z,
                           map.world(p.sacrum_body.a).z, kLabelSacrum});
  }
  for (const VertebraGeometry& v : vertebrae()) {
    if (!map.inside(v.body_centre())) continue;
    TrunkVertebra out{v.name,
                      map.world(v.body_centre()),
                      std::nullopt,
                      map.world({0.0, 0.0, v.z_lo}).z,
                      map.world({0.0, 0.0, v.z_hi}).z,
                      v.label};
    if (map.inside(v.spinous_tip())) out.spinous_tip = map.world(v.spinous_tip());
    t.vertebrae.push_back(out);
  }
}

void add_ribs_and_spaces(const WorldMap& map, TrunkTruth& t) {
  for (const RibGeometry& rib : ribs()) {
    TrunkRib out;
    out.side = side_of(rib.side);
    out.number = rib.number;
    out.radius = kRibRadius * map.frame.scale;
    out.label = rib_label(rib.side, rib.number);
    for (const Vec3d& p : rib.points)
      if (map.inside(p)) out.points.push_back(map.world(p));
    if (rib.mid_axillary_index >= 0) {
      const Vec3d& m = rib.points[static_cast<std::size_t>(rib.mid_axillary_index)];
      if (map.inside(m)) out.mid_axillary = map.world(m);
    }
    if (!out.points.empty()) t.ribs.push_back(out);
  }
  for (int side : {-1, 1}) {
    for (int upper = 8; upper <= 11; ++upper) {
      TrunkIntercostalSpace space;
      space.side = side_of(side);
      space.upper_rib = upper;
      const RibGeometry *a = nullptr, *b = nullptr;
      for (const RibGeometry& rib : ribs()) {
        if (rib.side != side) continue;
        if (rib.number == upper) a = &rib;
        if (rib.number == upper + 1) b = &rib;
      }
      if (a->mid_axillary_index < 0 || b->mid_axillary_index < 0) {
        space.reason = "rib " + std::to_string(upper + 1) + " ends behind the mid-axillary line";
      } else {
        const double z = (a->points[static_cast<std::size_t>(a->mid_axillary_index)].z +
                          b->points[static_cast<std::size_t>(b->mid_axillary_index)].z) /
                         2.0;
        const Vec3d skin = mid_axillary_skin(z, side);
        if (map.inside(skin)) {
          space.skin_point = map.world(skin);
          space.normal = skin_normal(skin);
        } else {
          space.reason = "outside the field of view";
        }
      }
      t.intercostal_spaces.push_back(space);
    }
  }
}

void add_pelvis(const WorldMap& map, TrunkTruth& t) {
  const PelvisGeometry& p = pelvis();
  double z_sum = 0.0;
  for (int n = 0; n < 2; ++n) {
    const int side = n == 0 ? -1 : 1;
    const auto i = static_cast<std::size_t>(n);
    t.iliac_crests.push_back(
        {side_of(side), map.world(p.crest_top[i]), map.world(p.asis[i]), hip_label(side)});
    z_sum += p.crest_top[i].z;
    const Vec3d artery = p.inguinal_artery[i];
    const Vec3d skin = skin_along_y(artery, -1.0);
    t.femoral_pulses.push_back({side_of(side), map.world(skin), skin_normal(skin),
                                map.world(artery), kArteryRadius * map.frame.scale});
  }
  t.tuffier_z = map.world({0.0, 0.0, z_sum / 2.0}).z;
  t.tuffier_level = vertebral_level(z_sum / 2.0);
  t.symphysis = map.world(p.symphysis);
  // Lumbar interspaces between adjacent spinous tips (S1: the first median sacral crest).
  const std::vector<VertebraGeometry>& v = vertebrae();
  const Vec3d crest_dir = p.s1_crest_tip - p.s1_crest_start;
  Vec3d below = p.s1_crest_tip + crest_dir * (kSpinousRadius / norm(crest_dir));
  std::string below_name = "S1";
  for (const VertebraGeometry& vertebra : v) {
    if (vertebra.thoracic) break;
    const Vec3d above = vertebra.spinous_tip();
    const Vec3d skin = skin_along_y((above + below) * 0.5, 1.0);
    if (map.inside(skin))
      t.lumbar_interspaces.insert(
          t.lumbar_interspaces.begin(),
          {vertebra.name + "/" + below_name, map.world(skin), skin_normal(skin)});
    below = above;
    below_name = vertebra.name;
  }
}

}  // namespace

TrunkTruth trunk_truth(const PhantomOptions& options) {
  PhantomOptions own = options;
  own.orient.reset();
  WorldMap map;
  map.grid = phantom_grid("trunk", own);
  map.frame = trunk_frame(map.grid);
  TrunkTruth t;
  add_vertebrae(map, t);
  add_ribs_and_spaces(map, t);
  add_pelvis(map, t);
  t.notes = {
      "the trunk phantom ends 9.5 mm above T8's superior endplate: no vertebra, rib, "
      "sternum or costal cartilage above it is drawn",
      "ribs 8-10 end in front without costal cartilage; rib 11 ends 12 degrees in front of the "
      "mid-axillary line, rib 12 34 degrees behind it (no 11th intercostal space at the "
      "mid-axillary line)"};
  return t;
}

std::string trunk_label_name(std::uint8_t label) {
  const int l = label;
  // (std::string(prefix) += number: GCC 12 warns falsely about "literal" + std::to_string)
  const auto join = [](const char* prefix, int number, const char* suffix) {
    std::string out(prefix);
    out += std::to_string(number);
    out += suffix;
    return out;
  };
  if (l >= 8 && l <= 12) return join("T", l, "");
  if (l >= 13 && l <= 17) return join("L", l - 12, "");
  if (l == kLabelSacrum) return "sacrum";
  if (l == kLabelCoccyx) return "coccyx";
  if (l >= 28 && l <= 32) return join("rib ", l - 20, " right");
  if (l >= 48 && l <= 52) return join("rib ", l - 40, " left");
  if (l == 60 || l == 61) return std::string("hip ") + (l == 60 ? "right" : "left");
  if (l == 62 || l == 63) return std::string("femur ") + (l == 62 ? "right" : "left");
  return "";
}

}  // namespace palp
