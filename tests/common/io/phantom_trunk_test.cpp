// The trunk phantom and its truth (io/phantom_trunk.hpp): every truth point checked against what
// the CT shows there (bone HU, soft tissue, the skin's boundary, the artery's lumen), the
// anatomy's order, the same patient whatever the storage order, and the options.
#include "io/phantom_trunk.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "io/phantom.hpp"

namespace palp {
namespace {

constexpr double kBoneHu = 200.0;

struct Drawn {
  CtVolume ct;
  PhantomTruth truth;
};

const Drawn& trunk() {
  static const Drawn d = [] {
    Drawn out;
    out.ct = make_phantom("trunk", {}, &out.truth);
    return out;
  }();
  return d;
}

Index3 voxel_of(const Grid& grid, const Vec3d& world) {
  const Vec3d s = scene_of_world(grid, world);
  return {std::llround(s.x / grid.spacing[0]), std::llround(s.y / grid.spacing[1]),
          std::llround(s.z / grid.spacing[2])};
}

template <class T>
T value_at(const Volume<T>& v, const Vec3d& world) {
  const Index3 i = voxel_of(v.grid, world);
  EXPECT_TRUE(v.grid.contains(i[0], i[1], i[2])) << world.x << " " << world.y << " " << world.z;
  if (!v.grid.contains(i[0], i[1], i[2])) return T{};
  return v.at(i[0], i[1], i[2]);
}

int hu(const Vec3d& world) {
  return value_at(trunk().ct, world);
}

// Any voxel whose centre lies within `radius` mm of `world` carrying `label`.
bool label_near(const Vec3d& world, double radius, std::uint8_t label) {
  const Mask& labels = trunk().truth.bone_label;
  const Grid& g = labels.grid;
  const Index3 c = voxel_of(g, world);
  for (std::int64_t k = c[2] - 3; k <= c[2] + 3; ++k)
    for (std::int64_t j = c[1] - 3; j <= c[1] + 3; ++j)
      for (std::int64_t i = c[0] - 3; i <= c[0] + 3; ++i) {
        if (!g.contains(i, j, k) || labels.at(i, j, k) != label) continue;
        const Vec3d w = world_of_scene(
            g, {static_cast<double>(i) * g.spacing[0], static_cast<double>(j) * g.spacing[1],
                static_cast<double>(k) * g.spacing[2]});
        if (norm(w - world) <= radius) return true;
      }
  return false;
}

// Half a voxel's diagonal and a millimetre: some voxel centre lies this close to any point.
constexpr double kNear = 3.3;

const TrunkVertebra& vertebra(const TrunkTruth& t, const std::string& name) {
  for (const TrunkVertebra& v : t.vertebrae)
    if (v.name == name) return v;
  throw std::runtime_error("no vertebra " + name);
}

const TrunkRib& rib(const TrunkTruth& t, TrunkSide side, int number) {
  for (const TrunkRib& r : t.ribs)
    if (r.side == side && r.number == number) return r;
  throw std::runtime_error(std::string("no rib ") += std::to_string(number));
}

TEST(TrunkPhantom, IsANamedPhantomOnItsDefaultGrid) {
  const auto names = phantom_names();
  EXPECT_NE(std::find(names.begin(), names.end(), "trunk"), names.end());
  const Grid g = phantom_grid("trunk");
  EXPECT_EQ(g.dims, (Index3{160, 120, 187}));
  EXPECT_EQ(g.spacing, (Vec3{2.5, 2.5, 3.0}));
  EXPECT_EQ(trunk().ct.grid, g);
  EXPECT_EQ(patient_frame(g).orientation_code(), "LPS");
  EXPECT_EQ(trunk().truth.bone_label.grid, g);
}

TEST(TrunkPhantom, VertebraeFromTheSacrumUpAreBoneWithDiscsBetween) {
  const TrunkTruth t = trunk_truth();
  const std::vector<std::string> names{"S",   "L5",  "L4",  "L3", "L2", "L1",
                                       "T12", "T11", "T10", "T9", "T8"};
  ASSERT_EQ(t.vertebrae.size(), names.size());
  for (std::size_t n = 0; n < names.size(); ++n) {
    const TrunkVertebra& v = t.vertebrae[n];
    EXPECT_EQ(v.name, names[n]);
    EXPECT_GT(hu(v.body_centre), kBoneHu) << v.name;
    EXPECT_EQ(value_at(trunk().truth.bone_label, v.body_centre), v.label) << v.name;
    EXPECT_EQ(trunk_label_name(v.label), v.name == "S" ? "sacrum" : v.name);
    if (n == 0) continue;
    EXPECT_GT(v.body_centre.z, t.vertebrae[n - 1].body_centre.z) << v.name;
    const double height = v.z_hi - v.z_lo;
    if (v.name[0] == 'T') {
      EXPECT_GE(height, 20.0) << v.name;
      EXPECT_LE(height, 25.0) << v.name;
    } else {
      EXPECT_GE(height, 26.0) << v.name;
      EXPECT_LE(height, 30.0) << v.name;
    }
    if (n + 1 < names.size()) {
      const TrunkVertebra& above = t.vertebrae[n + 1];
      const double disc = above.z_lo - v.z_hi;
      EXPECT_GE(disc, 5.0) << v.name;
      EXPECT_LE(disc, 10.0) << v.name;
      // the disc between them is soft tissue on the bodies' axis
      const Vec3d mid = (v.body_centre + above.body_centre) * 0.5;
      EXPECT_LT(hu({mid.x, mid.y, (v.z_hi + above.z_lo) / 2.0}), 150) << v.name;
    }
  }
  EXPECT_FALSE(t.vertebrae[0].spinous_tip);
}

TEST(TrunkPhantom, SpinousTipsAreBoneBehindTheBodies) {
  const TrunkTruth t = trunk_truth();
  for (const TrunkVertebra& v : t.vertebrae) {
    if (v.name == "S") continue;
    ASSERT_TRUE(v.spinous_tip) << v.name;
    const Vec3d tip = *v.spinous_tip;
    const double behind = tip.y - v.body_centre.y;
    EXPECT_GE(behind, 40.0) << v.name;
    EXPECT_LE(behind, 60.0) << v.name;
    EXPECT_NEAR(tip.x, 0.0, 1e-9);
    // bone just inside the tip, none a few mm beyond it (posteriorly)
    EXPECT_TRUE(label_near(tip, kNear, v.label))
        << v.name << " tip " << tip.x << " " << tip.y << " " << tip.z;
    EXPECT_LT(hu(tip + Vec3d{0.0, 4.0, 0.0}), 150) << v.name;
    if (v.name[0] == 'L') {
      EXPECT_NEAR(tip.z, v.body_centre.z, 2.0) << v.name;  // lumbar: horizontal
    } else {
      EXPECT_LT(tip.z, v.body_centre.z - 3.0) << v.name;  // thoracic: pointing down
    }
  }
}

TEST(TrunkPhantom, RibsAreBoneFromTheirVertebraAroundTheSide) {
  const TrunkTruth t = trunk_truth();
  ASSERT_EQ(t.ribs.size(), 10u);
  for (const TrunkRib& r : t.ribs) {
    const double s = r.side == TrunkSide::left ? 1.0 : -1.0;
    // (std::string(...) +=: GCC 12 warns falsely about "literal" + std::to_string)
    const TrunkVertebra& v = vertebra(t, std::string("T") += std::to_string(r.number));
    ASSERT_GE(r.points.size(), 5u);
    for (const Vec3d& p : r.points) {
      EXPECT_GT(hu(p), kBoneHu) << r.number << " at " << p.x << " " << p.y << " " << p.z;
      EXPECT_EQ(value_at(trunk().truth.bone_label, p), r.label) << r.number;
    }
    EXPECT_EQ(trunk_label_name(r.label),
              (std::string("rib ") += std::to_string(r.number)) += (s > 0 ? " left" : " right"));
    const Vec3d head = r.points.front();
    EXPECT_GE(head.z, v.z_lo) << r.number;
    EXPECT_LE(head.z, v.z_hi) << r.number;
    EXPECT_GT(s * head.x, 0.0);
    if (r.number <= 11) {
      ASSERT_TRUE(r.mid_axillary) << r.number;
      EXPECT_LT(r.mid_axillary->z, head.z) << r.number;
      if (r.number < 12) {
        const Vec3d next_head = rib(t, r.side, r.number + 1).points.front();
        EXPECT_GT(r.mid_axillary->z, next_head.z) << r.number;
      }
      EXPECT_GT(s * r.mid_axillary->x, 100.0);
    } else {
      EXPECT_FALSE(r.mid_axillary);
      EXPECT_GT(r.points.back().y, -25.0 + 20.0);  // rib 12 ends well behind the MAL's plane
    }
  }
}

TEST(TrunkPhantom, IntercostalSpacesAreSoftTissueGapsUnderTheSkinAtTheMidAxillaryLine) {
  const TrunkTruth t = trunk_truth();
  ASSERT_EQ(t.intercostal_spaces.size(), 8u);
  for (const TrunkIntercostalSpace& space : t.intercostal_spaces) {
    if (space.upper_rib == 11) {
      EXPECT_FALSE(space.skin_point);
      EXPECT_FALSE(space.reason.empty());
      continue;
    }
    ASSERT_TRUE(space.skin_point && space.normal) << space.upper_rib;
    const Vec3d p = *space.skin_point, n = *space.normal;
    EXPECT_NEAR(norm(n), 1.0, 1e-9);
    EXPECT_GT((space.side == TrunkSide::left ? 1.0 : -1.0) * n.x, 0.95);
    // on the skin: patient just inside, air just outside
    EXPECT_EQ(value_at(trunk().truth.body, p - n * 2.0), 1);
    EXPECT_EQ(value_at(trunk().truth.body, p + n * 2.0), 0);
    EXPECT_LT(hu(p + n * 3.0), -500);
    const TrunkRib& above = rib(t, space.side, space.upper_rib);
    const TrunkRib& below = rib(t, space.side, space.upper_rib + 1);
    EXPECT_LT(p.z, above.mid_axillary->z);
    EXPECT_GT(p.z, below.mid_axillary->z);
    // inward through the wall to beyond the ribs' depth: soft tissue only, the ribs above and
    // below at the same depth
    const double rib_depth = std::abs(p.x - above.mid_axillary->x);
    for (double d = 1.0; d <= rib_depth + 6.0; d += 1.0) {
      const int v = hu(p - n * d);
      EXPECT_GT(v, -200) << space.upper_rib << " depth " << d;
      EXPECT_LT(v, 150) << space.upper_rib << " depth " << d;
    }
    EXPECT_GT(hu(p - n * rib_depth + Vec3d{0, 0, above.mid_axillary->z - p.z}), kBoneHu);
    EXPECT_GT(hu(p - n * rib_depth + Vec3d{0, 0, below.mid_axillary->z - p.z}), kBoneHu);
  }
}

// The most superior voxel of one hip bone's label.
double top_of_label(std::uint8_t label, Vec3d* where) {
  const Mask& l = trunk().truth.bone_label;
  const Grid& g = l.grid;
  double best = -1e9;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        if (l.at(i, j, k) != label) continue;
        const Vec3d w = world_of_scene(
            g, {static_cast<double>(i) * g.spacing[0], static_cast<double>(j) * g.spacing[1],
                static_cast<double>(k) * g.spacing[2]});
        if (w.z > best) best = w.z, *where = w;
      }
  return best;
}

TEST(TrunkPhantom, IliacCrestTopsAreTheWingsHighestBoneAtTuffiersLevel) {
  const TrunkTruth t = trunk_truth();
  ASSERT_EQ(t.iliac_crests.size(), 2u);
  const double dz = trunk().ct.grid.spacing[2];
  for (const TrunkIliacCrest& c : t.iliac_crests) {
    Vec3d top_voxel;
    const double top = top_of_label(c.label, &top_voxel);
    EXPECT_NEAR(c.top.z, top + dz / 2.0, dz);  // the voxel's centre within a voxel of the edge
    EXPECT_LT(std::hypot(top_voxel.x - c.top.x, top_voxel.y - c.top.y), 15.0);
    EXPECT_TRUE(label_near(c.top, kNear, c.label));
    EXPECT_GT((c.side == TrunkSide::left ? 1.0 : -1.0) * c.top.x, 100.0);
    // the anterior superior iliac spine: in front, below the top, bone
    EXPECT_LT(c.anterior_superior_spine.y, c.top.y - 40.0);
    EXPECT_LT(c.anterior_superior_spine.z, c.top.z - 30.0);
    EXPECT_GT(hu(c.anterior_superior_spine), kBoneHu);
  }
  EXPECT_NEAR(t.tuffier_z, (t.iliac_crests[0].top.z + t.iliac_crests[1].top.z) / 2.0, 1e-9);
  const TrunkVertebra& l4 = vertebra(t, "L4");
  const TrunkVertebra& l5 = vertebra(t, "L5");
  EXPECT_GT(t.tuffier_z, l5.z_hi);
  EXPECT_LT(t.tuffier_z, l4.body_centre.z);
  EXPECT_EQ(t.tuffier_level, t.tuffier_z < l4.z_lo ? "L4/L5" : "L4");
}

TEST(TrunkPhantom, LumbarInterspacesAreOnTheBackMidlineBetweenSpinousTips) {
  const TrunkTruth t = trunk_truth();
  const std::vector<std::string> names{"L1/L2", "L2/L3", "L3/L4", "L4/L5", "L5/S1"};
  ASSERT_EQ(t.lumbar_interspaces.size(), names.size());
  for (std::size_t n = 0; n < names.size(); ++n) {
    const TrunkLumbarInterspace& l = t.lumbar_interspaces[n];
    EXPECT_EQ(l.name, names[n]);
    EXPECT_NEAR(l.skin_point.x, 0.0, 1e-9);
    EXPECT_GT(l.normal.y, 0.99);
    EXPECT_EQ(value_at(trunk().truth.body, l.skin_point - l.normal * 2.0), 1);
    EXPECT_EQ(value_at(trunk().truth.body, l.skin_point + l.normal * 2.0), 0);
    const TrunkVertebra& upper = vertebra(t, names[n].substr(0, 2));
    EXPECT_LT(l.skin_point.z, upper.spinous_tip->z) << l.name;
    if (names[n] != "L5/S1") {
      const TrunkVertebra& lower = vertebra(t, names[n].substr(3, 2));
      EXPECT_GT(l.skin_point.z, lower.spinous_tip->z) << l.name;
      EXPECT_NEAR(l.skin_point.z, (upper.spinous_tip->z + lower.spinous_tip->z) / 2.0, 1e-9);
    }
    // the needle's path from the skin toward the canal: no bone in its first 15 mm
    for (double d = 1.0; d <= 15.0; d += 1.0)
      EXPECT_LT(hu(l.skin_point - l.normal * d), 150) << l.name << " depth " << d;
  }
}

TEST(TrunkPhantom, FemoralPulsePointsLieOverTheArteryAtTheMidInguinalPoint) {
  const TrunkTruth t = trunk_truth();
  ASSERT_EQ(t.femoral_pulses.size(), 2u);
  for (std::size_t n = 0; n < 2; ++n) {
    const TrunkFemoralPulse& f = t.femoral_pulses[n];
    const TrunkIliacCrest& c = t.iliac_crests[n];
    EXPECT_EQ(f.side, c.side);
    const Vec3d mid = (c.anterior_superior_spine + t.symphysis) * 0.5;
    EXPECT_NEAR(f.skin_point.x, mid.x, 1e-6);
    EXPECT_NEAR(f.skin_point.z, mid.z, 1e-6);
    EXPECT_LT(f.normal.y, -0.9);  // anterior skin
    EXPECT_EQ(value_at(trunk().truth.body, f.skin_point - f.normal * 2.0), 1);
    EXPECT_EQ(value_at(trunk().truth.body, f.skin_point + f.normal * 2.0), 0);
    // straight in (posterior): artery lumen from 10 to 20 mm deep, none in the first 8 mm
    int lumen = 0;
    for (double d = 0.0; d <= 8.0; d += 1.0)
      EXPECT_EQ(value_at(trunk().truth.artery, f.skin_point + Vec3d{0, d, 0}), 0);
    for (double d = 10.0; d <= 20.0; d += 1.0)
      lumen += value_at(trunk().truth.artery, f.skin_point + Vec3d{0, d, 0});
    EXPECT_GE(lumen, 5);
    EXPECT_GT(hu(f.artery_centre), 150);  // contrast-filled lumen
    EXPECT_GE(f.artery_centre.y - f.skin_point.y, 10.0);
    EXPECT_LE(f.artery_centre.y - f.skin_point.y, 20.0);
  }
}

TEST(TrunkPhantom, TheTableIsUnderTheBackAndNotThePatient) {
  const Drawn& d = trunk();
  std::size_t equipment = 0, shared = 0;
  for (std::size_t i = 0; i < d.ct.size(); ++i) {
    equipment += d.truth.equipment.data[i];
    shared += d.truth.equipment.data[i] && d.truth.body.data[i];
  }
  EXPECT_GT(equipment, 10000u);
  EXPECT_EQ(shared, 0u);
}

TEST(TrunkPhantom, StoredInAnyOrderItIsTheSamePatientInTheSamePlace) {
  const Drawn& lps = trunk();
  const TrunkTruth truth = trunk_truth();
  for (const char* code : {"RAS", "LAS", "PIL", "ASR", "SRA"}) {
    PhantomOptions o;
    o.orient = code;
    PhantomTruth other_truth;
    const CtVolume other = make_phantom("trunk", o, &other_truth);
    EXPECT_EQ(other.grid, phantom_grid("trunk", o)) << code;
    EXPECT_EQ(patient_frame(other.grid).orientation_code(), code);
    // every voxel's world position keeps its HU and labels
    const Grid& g = lps.ct.grid;
    for (std::int64_t k = 0; k < g.dims[2]; k += 7)
      for (std::int64_t j = 0; j < g.dims[1]; j += 5)
        for (std::int64_t i = 0; i < g.dims[0]; i += 3) {
          const Vec3d w = world_of_scene(
              g, {static_cast<double>(i) * g.spacing[0], static_cast<double>(j) * g.spacing[1],
                  static_cast<double>(k) * g.spacing[2]});
          const Index3 o_idx = voxel_of(other.grid, w);
          ASSERT_TRUE(other.grid.contains(o_idx[0], o_idx[1], o_idx[2])) << code;
          const std::size_t a = g.linear(i, j, k);
          const std::size_t b = other.grid.linear(o_idx[0], o_idx[1], o_idx[2]);
          ASSERT_EQ(lps.ct.data[a], other.data[b]) << code;
          ASSERT_EQ(lps.truth.bone_label.data[a], other_truth.bone_label.data[b]) << code;
          ASSERT_EQ(lps.truth.artery.data[a], other_truth.artery.data[b]) << code;
        }
    // the truth in world coordinates does not move
    const TrunkTruth t = trunk_truth(o);
    ASSERT_EQ(t.vertebrae.size(), truth.vertebrae.size());
    for (std::size_t n = 0; n < t.vertebrae.size(); ++n)
      EXPECT_EQ(t.vertebrae[n].body_centre, truth.vertebrae[n].body_centre) << code;
    EXPECT_EQ(t.femoral_pulses[0].skin_point, truth.femoral_pulses[0].skin_point) << code;
  }
}

TEST(TrunkPhantom, OrientWorksForTheTorsoToo) {
  PhantomOptions o;
  o.orient = "RAS";
  const CtVolume ras = make_phantom("torso", o);
  const CtVolume lps = make_phantom("torso");
  EXPECT_EQ(patient_frame(ras.grid).orientation_code(), "RAS");
  const Grid& g = lps.grid;
  // RAS flips x and y: voxel (i, j, k) of LPS is (nx-1-i, ny-1-j, k) of RAS
  for (std::int64_t k = 0; k < g.dims[2]; k += 11)
    for (std::int64_t j = 0; j < g.dims[1]; j += 7)
      for (std::int64_t i = 0; i < g.dims[0]; i += 5)
        ASSERT_EQ(lps.at(i, j, k), ras.at(g.dims[0] - 1 - i, g.dims[1] - 1 - j, k));
  EXPECT_EQ(world_of_scene(ras.grid, {0, 0, 0}),
            world_of_scene(g, {static_cast<double>(g.dims[0] - 1) * g.spacing[0],
                               static_cast<double>(g.dims[1] - 1) * g.spacing[1], 0.0}));
}

TEST(TrunkPhantom, OptionsAndSpecs) {
  const PhantomSpec spec = parse_phantom_spec("trunk,orient=RAS,contrast=arterial,structures");
  EXPECT_EQ(spec.name, "trunk");
  EXPECT_EQ(spec.options.orient, "RAS");
  EXPECT_EQ(spec.options.contrast, PhantomContrast::arterial);
  EXPECT_THROW(parse_phantom_spec("trunk,arms=2"), UsageError);
  EXPECT_THROW(parse_phantom_spec("trunk,metal"), UsageError);
  EXPECT_THROW(parse_phantom_spec("trunk,orient=LPX"), UsageError);
  EXPECT_THROW(parse_phantom_spec("trunk,orient=LLS"), UsageError);
  EXPECT_EQ(parse_phantom_spec("cube,orient=LPS").options.orient, "LPS");
  // the aorta's HU follows the contrast options
  PhantomOptions bright;
  bright.aorta_hu = 500.0;
  const CtVolume ct = make_phantom("trunk", bright);
  const TrunkTruth t = trunk_truth(bright);
  EXPECT_GT(value_at(ct, t.femoral_pulses[0].artery_centre), 400);
}

TEST(TrunkPhantom, AThinSlabListsOnlyWhatItShows) {
  PhantomOptions o;
  o.dims = Index3{160, 120, 40};  // 120 mm around the middle: L5 to L3
  const TrunkTruth t = trunk_truth(o);
  const Grid g = phantom_grid("trunk", o);
  for (const TrunkVertebra& v : t.vertebrae) {
    EXPECT_GT(v.body_centre.z, g.world.origin[2] - 1.5) << v.name;
    EXPECT_LT(v.body_centre.z, g.world.origin[2] + 117.0 + 1.5) << v.name;
  }
  EXPECT_LT(t.vertebrae.size(), 6u);
  EXPECT_TRUE(t.ribs.empty() || t.ribs.size() < 10u);
  // the same anatomy in the same place as on the full grid
  const TrunkTruth full = trunk_truth();
  EXPECT_EQ(vertebra(t, "L3").body_centre, vertebra(full, "L3").body_centre);
}

TEST(TrunkPhantom, LabelsNameEveryBone) {
  std::map<std::string, int> seen;
  for (std::uint8_t l : trunk().truth.bone_label.data) seen[trunk_label_name(l)] += 1;
  for (const char* name : {"T8", "T12", "L1", "L5", "sacrum", "coccyx", "rib 8 right",
                           "rib 12 left", "hip right", "hip left", "femur right", "femur left"})
    EXPECT_GT(seen[name], 0) << name;
  // every bone voxel carries a label, no label lies outside the bone
  const Drawn& d = trunk();
  for (std::size_t i = 0; i < d.ct.size(); ++i)
    ASSERT_EQ(d.truth.bone.data[i] != 0, d.truth.bone_label.data[i] != 0) << i;
}

}  // namespace
}  // namespace palp
