// Tests for the synthetic CTs (common/io/phantom.cpp, phantom_torso.cpp): names and grids, the
// cube's flat faces, the sphere against its analytic geometry, the torso's structures, truth masks
// and grid overrides, and its options (contrast phases, aorta HU, arms, metal, thin slabs, the
// phantom:NAME,KEY=VALUE scene string); the default torso stays byte for byte what it was.
#include "io/phantom.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "support/torso_scenes.hpp"

namespace palp {
namespace {

std::int64_t count(const Mask& m) {
  return std::count_if(m.data.begin(), m.data.end(), [](std::uint8_t v) { return v != 0; });
}

std::int64_t count_both(const Mask& a, const Mask& b) {
  std::int64_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += a.data[i] && b.data[i];
  return n;
}

double ml(const Grid& g, std::int64_t voxels) {
  return static_cast<double>(voxels) * g.spacing[0] * g.spacing[1] * g.spacing[2] / 1000.0;
}

// Number of 4-connected components of the nonzero voxels of slice k.
int components_in_slice(const Mask& m, std::int64_t k) {
  const Grid& g = m.grid;
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(g.dims[0] * g.dims[1]), 0);
  std::vector<std::int64_t> stack;
  int components = 0;
  for (std::int64_t start = 0; start < g.dims[0] * g.dims[1]; ++start) {
    if (seen[start] || !m.at(start % g.dims[0], start / g.dims[0], k)) continue;
    ++components;
    stack.push_back(start);
    seen[start] = 1;
    while (!stack.empty()) {
      const std::int64_t n = stack.back();
      stack.pop_back();
      const std::int64_t i = n % g.dims[0], j = n / g.dims[0];
      const std::int64_t next[4][2] = {{i - 1, j}, {i + 1, j}, {i, j - 1}, {i, j + 1}};
      for (const auto& q : next) {
        if (!g.contains(q[0], q[1], k) || !m.at(q[0], q[1], k)) continue;
        const std::int64_t id = q[0] + g.dims[0] * q[1];
        if (!seen[id]) seen[id] = 1, stack.push_back(id);
      }
    }
  }
  return components;
}

TEST(Phantom, NamesAndErrors) {
  const auto names = phantom_names();
  for (const char* n : {"cube", "sphere", "torso"})
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
  EXPECT_THROW(make_phantom("dodecahedron"), UsageError);
  PhantomOptions bad;
  bad.dims = Index3{0, 10, 10};
  EXPECT_THROW(make_phantom("cube", bad), UsageError);
  bad.dims.reset();
  bad.spacing = Vec3{1.0, -1.0, 1.0};
  EXPECT_THROW(make_phantom("sphere", bad), UsageError);
}

TEST(Phantom, CubeIsASoftTissueBlockWithFlatFacesBetweenVoxelCentres) {
  PhantomTruth truth;
  const CtVolume ct = make_phantom("cube", {}, &truth);
  const Grid& g = ct.grid;
  EXPECT_EQ(g.dims, (Index3{140, 140, 140}));
  EXPECT_EQ(g.spacing, (Vec3{1.0, 1.0, 1.0}));
  const BoxGeometry box = cube_geometry(g);
  for (int a = 0; a < 3; ++a) {
    EXPECT_GE(box.max[a] - box.min[a], 80.0);
    EXPECT_GE(box.min[a], 20.0 - 0.5) << "air margin";
    EXPECT_LE(box.max[a], g.extent_mm()[a] - 20.0 + 0.5) << "air margin";
    EXPECT_NEAR(box.min[a] - std::floor(box.min[a]), 0.5, 1e-9) << "face between voxel centres";
    EXPECT_NEAR(box.max[a] - std::floor(box.max[a]), 0.5, 1e-9);
  }
  std::int64_t wrong = 0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const bool inside = i > box.min[0] && i < box.max[0] && j > box.min[1] && j < box.max[1] &&
                            k > box.min[2] && k < box.max[2];
        wrong += ct.at(i, j, k) != (inside ? 40 : -1000);
        wrong += truth.body.at(i, j, k) != (inside ? 1 : 0);
      }
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(count(truth.bone), 0);
  EXPECT_EQ(count(truth.equipment), 0);
  // The top face (+z) is flat: the last tissue layer is full, the layer above is air.
  const auto top = static_cast<std::int64_t>(std::floor(box.max[2]));
  const auto mid = static_cast<std::int64_t>((box.min[0] + box.max[0]) / 2.0);
  EXPECT_EQ(ct.at(mid, mid, top), 40);
  EXPECT_EQ(ct.at(mid, mid, top + 1), -1000);
}

TEST(Phantom, SphereMatchesItsAnalyticGeometry) {
  PhantomTruth truth;
  const CtVolume ct = make_phantom("sphere", {}, &truth);
  const Grid& g = ct.grid;
  EXPECT_EQ(g.dims, (Index3{100, 100, 100}));
  const SphereGeometry s = sphere_geometry(g);
  EXPECT_DOUBLE_EQ(s.radius, 30.0);
  for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(s.centre[a], 49.5);
  std::int64_t wrong = 0, inside = 0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const double d = std::hypot(i - s.centre[0], j - s.centre[1], k - s.centre[2]);
        const bool in = d <= s.radius;
        inside += in;
        wrong += ct.at(i, j, k) != (in ? 40 : -1000);
        wrong += truth.body.at(i, j, k) != (in ? 1 : 0);
      }
  EXPECT_EQ(wrong, 0);
  const double volume = 4.0 / 3.0 * std::numbers::pi * std::pow(s.radius, 3);
  EXPECT_NEAR(static_cast<double>(inside), volume, 0.01 * volume);
}

TEST(Phantom, SphereScalesDownWithASmallerFieldOfView) {
  PhantomOptions o;
  o.dims = Index3{50, 48, 46};
  o.spacing = Vec3{2.0, 2.0, 2.5};
  const CtVolume ct = make_phantom("sphere", o);
  const SphereGeometry s = sphere_geometry(ct.grid);
  EXPECT_NEAR(s.radius, 30.0 * 96.0 / 100.0, 1e-9);  // fits the 96 mm axis
  for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(s.centre[a], ct.grid.extent_mm()[a] / 2.0);
  for (int a = 0; a < 3; ++a) {
    EXPECT_GT(s.centre[a] - s.radius, 0.0);
    EXPECT_LT(s.centre[a] + s.radius, ct.grid.extent_mm()[a]);
  }
}

class TorsoTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    truth_ = new PhantomTruth;
    const auto start = std::chrono::steady_clock::now();
    ct_ = new CtVolume(make_phantom("torso", {}, truth_));
    draw_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  static void TearDownTestSuite() {
    delete ct_;
    delete truth_;
  }
  static CtVolume* ct_;
  static PhantomTruth* truth_;
  static double draw_seconds_;
};
CtVolume* TorsoTest::ct_ = nullptr;
PhantomTruth* TorsoTest::truth_ = nullptr;
double TorsoTest::draw_seconds_ = 0.0;

TEST_F(TorsoTest, DefaultGridAndPlacement) {
  const Grid& g = ct_->grid;
  EXPECT_EQ(g.dims, (Index3{384, 256, 96}));
  EXPECT_EQ(g.spacing, (Vec3{1.25, 1.25, 2.0}));
  EXPECT_EQ(g.world.direction, (std::array<double, 9>{1, 0, 0, 0, 1, 0, 0, 0, 1}));
  for (int a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(g.world.origin[a], -g.extent_mm()[a] / 2.0);
  EXPECT_LT(draw_seconds_, 5.0);
}

TEST_F(TorsoTest, IsDeterministic) {
  const CtVolume again = make_phantom("torso");
  EXPECT_TRUE(again.data == ct_->data);
}

// FNV-1a over the bytes of a volume's voxels.
template <class T>
std::uint64_t fnv1a(const Volume<T>& v) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  const auto* bytes = reinterpret_cast<const unsigned char*>(v.data.data());
  for (std::size_t n = 0; n < v.data.size() * sizeof(T); ++n) h = (h ^ bytes[n]) * 0x100000001b3ull;
  return h;
}

// The default torso is what tests and recorded outputs elsewhere were made on: the options added
// later (contrast, arms, metal) leave it byte for byte as it was (hashes taken before them).
TEST_F(TorsoTest, DefaultIsByteIdenticalToTheRecordedOne) {
  EXPECT_EQ(fnv1a(*ct_), 0x8efb89f7be5aa73eull);
  EXPECT_EQ(fnv1a(truth_->body), 0xe263e41aca2dcba5ull);
  EXPECT_EQ(fnv1a(truth_->bone), 0xfeacea0351f2e599ull);
  EXPECT_EQ(fnv1a(truth_->equipment), 0x43267f2fbb1938a5ull);
}

TEST_F(TorsoTest, HasTableBoardPadAndCableBelowThePatient) {
  const Grid& g = ct_->grid;
  const Mask& equipment = truth_->equipment;
  EXPECT_GT(ml(g, count(equipment)), 1000.0);
  // The board crosses the whole width: some row is above +200 HU from edge to edge, in every slice.
  for (std::int64_t k = 0; k < g.dims[2]; ++k) {
    bool crossing = false;
    for (std::int64_t j = 0; j < g.dims[1] && !crossing; ++j) {
      crossing = true;
      for (std::int64_t i = 0; i < g.dims[0] && crossing; ++i) crossing = ct_->at(i, j, k) > 200;
    }
    EXPECT_TRUE(crossing) << "slice " << k;
  }
  // The pad (soft-tissue-like, around -100 HU) touches the back; the cable (+200 HU) lies on it.
  std::int64_t pad_contacts = 0, cable = 0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j + 1 < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        if (truth_->body.at(i, j, k) && equipment.at(i, j + 1, k) && ct_->at(i, j + 1, k) < 0)
          ++pad_contacts;
        if (!equipment.at(i, j, k) || ct_->at(i, j, k) < 150 || ct_->at(i, j, k) > 250) continue;
        for (std::int64_t below = j + 1; below <= std::min(j + 3, g.dims[1] - 1); ++below)
          if (equipment.at(i, below, k) && ct_->at(i, below, k) < 0) {
            ++cable;  // cable voxel with the pad just below it
            break;
          }
      }
  EXPECT_GT(pad_contacts, 10 * g.dims[2]);
  EXPECT_GT(cable, g.dims[2]);
  // Nothing of the equipment is body or bone.
  for (std::size_t n = 0; n < equipment.size(); ++n)
    ASSERT_FALSE(equipment.data[n] && (truth_->body.data[n] || truth_->bone.data[n]));
}

TEST_F(TorsoTest, HasBonesWithCortexAndMarrow) {
  const Grid& g = ct_->grid;
  const double bone_ml = ml(g, count(truth_->bone));
  EXPECT_GT(bone_ml, 250.0);
  EXPECT_LT(bone_ml, 600.0);
  std::int64_t cortex = 0, marrow = 0, outside_body = 0;
  for (std::size_t n = 0; n < truth_->bone.size(); ++n) {
    if (!truth_->bone.data[n]) continue;
    cortex += ct_->data[n] > 800;
    marrow += ct_->data[n] > 200 && ct_->data[n] < 300;
    outside_body += !truth_->body.data[n];
  }
  EXPECT_GT(cortex, 10000);
  EXPECT_GT(marrow, 20000);
  EXPECT_EQ(outside_body, 0);
  // Ribs with intercostal spaces: going up the lateral wall, bone comes and goes several times.
  const std::int64_t i = g.dims[0] / 2 + static_cast<std::int64_t>(120.0 / g.spacing[0]);
  const std::int64_t j = g.dims[1] / 2 - static_cast<std::int64_t>(20.0 / g.spacing[1]);
  int ribs = 0;
  for (std::int64_t k = 1; k < g.dims[2]; ++k) {
    bool any = false, any_below = false;
    for (std::int64_t jj = j - 40; jj <= j + 40; ++jj) {
      any = any || truth_->bone.at(i, jj, k);
      any_below = any_below || truth_->bone.at(i, jj, k - 1);
    }
    ribs += any && !any_below;
  }
  EXPECT_GE(ribs, 4);
}

TEST_F(TorsoTest, LungsReachTheTopSliceAndGasTheBottomOne) {
  const Grid& g = ct_->grid;
  std::int64_t lung_top = 0, gas_bottom = 0;
  for (std::int64_t j = 0; j < g.dims[1]; ++j)
    for (std::int64_t i = 0; i < g.dims[0]; ++i) {
      lung_top += truth_->body.at(i, j, g.dims[2] - 1) && ct_->at(i, j, g.dims[2] - 1) < -700;
      gas_bottom += truth_->body.at(i, j, 0) && ct_->at(i, j, 0) < -900;
    }
  EXPECT_GT(ml(g, lung_top) / (g.spacing[2] / 10.0), 50.0) << "cm^2 of lung in the top slice";
  EXPECT_GT(gas_bottom, 100);
}

TEST_F(TorsoTest, ContrastAortaTouchesTheSpine) {
  const Grid& g = ct_->grid;
  std::int64_t contacts = 0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 1; j + 1 < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const int hu = ct_->at(i, j, k);
        if (hu < 235 || hu > 265 || truth_->bone.at(i, j, k)) continue;
        if (truth_->bone.at(i, j + 1, k) && ct_->at(i, j + 1, k) > 500) ++contacts;
      }
  EXPECT_GT(contacts, g.dims[2]);
}

TEST_F(TorsoTest, ArmIsASeparatePartBesideTheTorso) {
  const Grid& g = ct_->grid;
  for (std::int64_t k : {std::int64_t{0}, g.dims[2] / 2, g.dims[2] - 1})
    EXPECT_EQ(components_in_slice(truth_->body, k), 2) << "slice " << k;
}

TEST(Phantom, TorsoGridOverridesKeepTheWholeScene) {
  PhantomOptions o;
  o.dims = Index3{384, 384, 160};
  o.spacing = Vec3{0.8, 0.8, 1.5};
  PhantomTruth truth;
  const CtVolume ct = make_phantom("torso", o, &truth);
  const Grid& g = ct.grid;
  EXPECT_EQ(g.dims, *o.dims);
  EXPECT_EQ(g.spacing, *o.spacing);
  std::int64_t at_border = 0, lung_top = 0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        if (!truth.body.at(i, j, k)) continue;
        at_border += i == 0 || i == g.dims[0] - 1 || j == 0 || j == g.dims[1] - 1;
        lung_top += k == g.dims[2] - 1 && ct.at(i, j, k) < -700;
      }
  EXPECT_EQ(at_border, 0) << "the torso and the arm fit across the field of view";
  EXPECT_GT(lung_top, 1000);
  EXPECT_GT(count(truth.bone), 0);
  EXPECT_GT(count(truth.equipment), 0);
  EXPECT_EQ(components_in_slice(truth.body, g.dims[2] / 2), 2);
}

// ---------------------------------------------------------------------------------------------
// Torso options (issue 38): contrast phases, aorta HU, arms, metal, thin slabs, scene strings.

using Drawn = testing::DrawnTorso;
using testing::torso_with;

PhantomOptions with_contrast(PhantomContrast c) {
  PhantomOptions o;
  o.contrast = c;
  return o;
}

// HU of the voxels of `m`, sorted.
std::vector<int> hu_in(const CtVolume& ct, const Mask& m) {
  std::vector<int> out;
  for (std::size_t n = 0; n < m.size(); ++n)
    if (m.data[n]) out.push_back(ct.data[n]);
  std::sort(out.begin(), out.end());
  return out;
}

// Every truth mask of the vessels lies in the body and outside the bone.
void expect_vessels_in_soft_body(const PhantomTruth& t) {
  for (std::size_t n = 0; n < t.body.size(); ++n) {
    ASSERT_FALSE((t.vessel.data[n] || t.artery.data[n]) && !t.body.data[n]) << n;
    ASSERT_FALSE((t.vessel.data[n] || t.artery.data[n]) && t.bone.data[n]) << n;
  }
}

TEST_F(TorsoTest, DefaultVesselTruthIsTheContrastAortaAlone) {
  EXPECT_TRUE(truth_->vessel.data == truth_->artery.data);
  EXPECT_EQ(count(truth_->metal), 0);
  const std::vector<int> hu = hu_in(*ct_, truth_->vessel);
  ASSERT_FALSE(hu.empty());
  EXPECT_GT(hu.front(), 130) << "even a half-covered edge voxel is above (40 + 250) / 2 - noise";
  EXPECT_NEAR(hu[hu.size() / 2], 250, 12);
  // a cylinder of 12 mm radius through the whole field of view, less what the spine covers
  const double full_ml = 3.14159 * 12.0 * 12.0 * ct_->grid.extent_mm()[2] / 1000.0;
  EXPECT_NEAR(ml(ct_->grid, count(truth_->vessel)), full_ml, 0.15 * full_ml);
  expect_vessels_in_soft_body(*truth_);
}

TEST(PhantomContrast, ArterialPhaseLightsTheArteriesNotTheVeins) {
  const Drawn art = torso_with(with_contrast(PhantomContrast::arterial));
  const Drawn pv = torso_with(with_contrast(PhantomContrast::portal_venous));
  expect_vessels_in_soft_body(art.truth);
  // the arteries only: every contrast-truth voxel is an artery's
  EXPECT_TRUE(art.truth.vessel.data == art.truth.artery.data);
  const std::vector<int> hu = hu_in(art.ct, art.truth.vessel);
  ASSERT_FALSE(hu.empty());
  EXPECT_GT(hu.front(), 200) << "even a half-covered edge voxel is above (40 + 400) / 2 - noise";
  EXPECT_GT(hu[hu.size() / 10], 300) << "90 % of the lumen reads above 300 HU (3 mm branches)";
  EXPECT_NEAR(hu[hu.size() / 2], 400, 12);
  // the aorta and more: branches leave it (the default's aorta alone is ~ 70 ml)
  EXPECT_GT(ml(art.ct.grid, count(art.truth.artery)), 75.0);
  // The veins (the portal-venous phase's contrast truth less its arteries) are drawn in the
  // arterial phase too, below 100 HU and outside its contrast truth.
  Mask veins(pv.ct.grid, 0);
  for (std::size_t n = 0; n < veins.size(); ++n)
    veins.data[n] = pv.truth.vessel.data[n] && !pv.truth.artery.data[n];
  EXPECT_GT(ml(veins.grid, count(veins)), 20.0);
  EXPECT_EQ(count_both(veins, art.truth.vessel), 0);
  const std::vector<int> vein_hu = hu_in(art.ct, veins);
  EXPECT_LT(vein_hu[vein_hu.size() / 2], 100);
  EXPECT_GT(vein_hu[vein_hu.size() * 9 / 10], 70) << "the veins above the renals: 85-95 HU";
}

TEST(PhantomContrast, PortalVenousPhaseLightsArteriesAndVeins) {
  const Drawn pv = torso_with(with_contrast(PhantomContrast::portal_venous));
  expect_vessels_in_soft_body(pv.truth);
  const std::vector<int> hu = hu_in(pv.ct, pv.truth.vessel);
  ASSERT_FALSE(hu.empty());
  EXPECT_GT(hu.front(), 70) << "half-covered edge voxels of the 130 HU infrarenal IVC";
  EXPECT_GT(hu[hu.size() / 2], 140);
  EXPECT_GT(count(pv.truth.vessel), count(pv.truth.artery) * 3 / 2) << "veins are contrast too";
  for (std::size_t n = 0; n < pv.truth.artery.size(); ++n)
    ASSERT_FALSE(pv.truth.artery.data[n] && !pv.truth.vessel.data[n]) << n;
}

TEST(PhantomContrast, WithoutContrastNoVesselIsContrastTruthButTheArteriesAreDrawn) {
  const Drawn none = torso_with(with_contrast(PhantomContrast::none));
  EXPECT_EQ(count(none.truth.vessel), 0);
  const std::vector<int> hu = hu_in(none.ct, none.truth.artery);
  ASSERT_GT(ml(none.ct.grid, static_cast<std::int64_t>(hu.size())), 75.0);
  EXPECT_NEAR(hu[hu.size() / 2], 40, 12);
  EXPECT_LT(hu[hu.size() * 99 / 100], 200) << "nothing bright but where bone blends in";
}

TEST(PhantomContrast, AortaHuSetsTheArteriesAndDecidesWhatIsContrastTruth) {
  PhantomOptions o;
  o.aorta_hu = 150.0;
  const Drawn a150 = torso_with(o);
  const std::vector<int> hu = hu_in(a150.ct, a150.truth.vessel);
  ASSERT_FALSE(hu.empty());
  EXPECT_NEAR(hu[hu.size() / 2], 150, 12);
  EXPECT_TRUE(a150.truth.vessel.data == a150.truth.artery.data) << "arterial-phase veins";
  o.aorta_hu = 80.0;  // less than 60 HU above soft tissue: drawn, not contrast truth
  const Drawn a80 = torso_with(o);
  EXPECT_EQ(count(a80.truth.vessel), 0);
  EXPECT_EQ(count(a80.truth.artery), count(a150.truth.artery));
  // aorta 400 alone is the arterial phase
  o.aorta_hu = 400.0;
  EXPECT_TRUE(make_phantom("torso", o).data ==
              make_phantom("torso", with_contrast(PhantomContrast::arterial)).data);
}

TEST(PhantomDissection, AFalseLumenAtSoftTissueHuInPeriaorticFat) {
  // The same arterial tree with the aorta dissected: the truth vessel keeps its size (both lumens
  // are the aorta's), about two thirds of the aorta's section (1 - (7/12)^2) now reads at the
  // false lumen's 50 HU instead of 400, and fat (-100 HU) lies beside the truth vessel, where the
  // undissected aorta lies in the abdomen's soft tissue.
  PhantomOptions dissected = with_contrast(PhantomContrast::arterial);
  dissected.dissection = true;
  const Drawn d = torso_with(dissected);
  const Drawn a = torso_with(with_contrast(PhantomContrast::arterial));
  expect_vessels_in_soft_body(d.truth);
  const double vessel = static_cast<double>(count(d.truth.vessel));
  EXPECT_NEAR(vessel / static_cast<double>(count(a.truth.vessel)), 1.0, 0.03);
  const auto below = [](const Drawn& x, int hu) {
    std::int64_t n = 0;
    for (const int v : hu_in(x.ct, x.truth.vessel)) n += v < hu;
    return n;
  };
  EXPECT_GT(static_cast<double>(below(d, 150)), 0.4 * vessel);
  EXPECT_EQ(below(a, 150), 0);
  const auto fat_beside = [](const Drawn& x) {
    const Grid& g = x.ct.grid;
    std::int64_t n = 0;
    for (std::int64_t k = 0; k < g.dims[2]; ++k)
      for (std::int64_t j = 0; j < g.dims[1]; ++j)
        for (std::int64_t i = 1; i + 1 < g.dims[0]; ++i)
          n += x.ct.at(i, j, k) < -60 && x.truth.body.at(i, j, k) &&
               (x.truth.vessel.at(i - 1, j, k) || x.truth.vessel.at(i + 1, j, k));
    return n;
  };
  EXPECT_GT(fat_beside(d), 10 * fat_beside(a) + 100);
  // a scene string draws it too
  EXPECT_TRUE(parse_phantom_spec("torso,contrast=arterial,dissection").options.dissection);
  EXPECT_THROW(make_phantom("trunk", dissected), UsageError);
  // with structures but no vessel tree there is no aorta of the tree to dissect: refused
  EXPECT_THROW(parse_phantom_spec("torso,structures,dissection"), UsageError);
  EXPECT_NO_THROW(parse_phantom_spec("torso,structures,dissection,contrast=arterial"));
}

TEST(PhantomArms, TwoArmsOrNone) {
  PhantomOptions o;
  o.arms = 2;
  const Drawn two = torso_with(o);
  const Grid& g = two.ct.grid;
  for (std::int64_t k : {std::int64_t{0}, g.dims[2] / 2, g.dims[2] - 1})
    EXPECT_EQ(components_in_slice(two.truth.body, k), 3) << "slice " << k;
  std::int64_t at_border = 0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      at_border += two.truth.body.at(0, j, k) + two.truth.body.at(g.dims[0] - 1, j, k);
  EXPECT_EQ(at_border, 0) << "both arms fit across the field of view";
  o.arms = 0;
  const Drawn none = torso_with(o);
  EXPECT_EQ(components_in_slice(none.truth.body, g.dims[2] / 2), 1);
  EXPECT_GT(count(two.truth.bone), count(none.truth.bone));
}

TEST(PhantomMetal, ScrewsInAVertebraWithStreaksInTheirSlicesOnly) {
  PhantomOptions o;
  o.metal = true;
  const Drawn metal = torso_with(o);
  PhantomTruth plain_truth;
  const CtVolume plain = make_phantom("torso", {}, &plain_truth);
  const Grid& g = plain.grid;
  const std::vector<int> hu = hu_in(metal.ct, metal.truth.metal);
  ASSERT_GT(hu.size(), 200u);
  EXPECT_GT(hu.front(), 1700) << "half-covered edge voxels of a 3500 HU screw";
  EXPECT_GT(hu.back(), 3400);
  for (std::size_t n = 0; n < g.voxel_count(); ++n)
    ASSERT_FALSE(metal.truth.metal.data[n] && !metal.truth.bone.data[n]) << n;
  // Streaks: far from the screws, patient voxels differ from the plain torso by hundreds of HU,
  // both ways, in the screws' slices; slices away from them are the plain torso's.
  std::int64_t bright = 0, dark = 0, changed_elsewhere = 0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k) {
    const double z = static_cast<double>(k) * g.spacing[2] - g.extent_mm()[2] / 2.0;
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const std::size_t n = g.linear(i, j, k);
        const int diff = metal.ct.data[n] - plain.data[n];
        if (std::abs(z - 8.0) > 6.0) {
          changed_elsewhere += diff != 0;
          continue;
        }
        if (metal.truth.metal.data[n] || !plain_truth.body.data[n]) continue;
        bright += diff > 300, dark += diff < -300;
      }
  }
  EXPECT_GT(bright, 400) << bright << " bright, " << dark << " dark";
  EXPECT_GT(dark, 400);
  EXPECT_EQ(changed_elsewhere, 0);
  // outside the body the streaks change nothing
  for (std::size_t n = 0; n < g.voxel_count(); ++n)
    if (!plain_truth.body.data[n]) {
      ASSERT_EQ(metal.ct.data[n], plain.data[n]) << n;
    }
}

TEST_F(TorsoTest, ThinSlabIsTheMiddleOfTheSameTorsoNotRescaled) {
  PhantomOptions o;
  o.dims = Index3{384, 256, 20};
  const Drawn slab = torso_with(o);
  const Grid& g = slab.ct.grid;
  const std::int64_t shift = (ct_->grid.dims[2] - g.dims[2]) / 2;  // 38 slices of 2 mm
  int worst = 0;
  std::int64_t truth_differs = 0;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        worst = std::max(worst, std::abs(slab.ct.at(i, j, k) - ct_->at(i, j, k + shift)));
        truth_differs += slab.truth.bone.at(i, j, k) != truth_->bone.at(i, j, k + shift);
      }
  EXPECT_LE(worst, 20) << "the same anatomy; only the noise, indexed by voxel, differs";
  EXPECT_EQ(truth_differs, 0);
}

TEST(PhantomSpec, ParsesNameAndOptions) {
  const PhantomSpec s = parse_phantom_spec(
      "torso,contrast=portal-venous,aorta-hu=300,arms=2,metal,dims=10x12x14,spacing=1x1x2.5");
  EXPECT_EQ(s.name, "torso");
  EXPECT_EQ(s.options.contrast, PhantomContrast::portal_venous);
  EXPECT_EQ(s.options.aorta_hu, 300.0);
  EXPECT_EQ(s.options.arms, 2);
  EXPECT_TRUE(s.options.metal);
  EXPECT_EQ(s.options.dims, (Index3{10, 12, 14}));
  EXPECT_EQ(s.options.spacing, (Vec3{1.0, 1.0, 2.5}));
  EXPECT_EQ(parse_phantom_spec("torso").name, "torso");
  EXPECT_FALSE(parse_phantom_spec("torso,metal=0").options.metal);
  for (const char* bad : {"torso,contrast=venous", "torso,arms=3", "torso,aorta-hu=abc",
                          "torso,contrast", "torso,colour=red", "cube,metal", "sphere,arms=2",
                          "torso,dims=10x10", "torso,aorta-hu=5000"})
    EXPECT_THROW(parse_phantom_spec(bad), UsageError) << bad;
}

TEST(PhantomSpec, ReadCtDrawsTheOptions) {
  PhantomOptions o;
  o.dims = Index3{96, 64, 12};
  o.contrast = PhantomContrast::arterial;
  o.arms = 2;
  const CtVolume read = read_ct("phantom:torso,dims=96x64x12,contrast=arterial,arms=2");
  EXPECT_TRUE(read.data == make_phantom("torso", o).data);
  PhantomOptions grid_only;
  grid_only.dims = o.dims;
  EXPECT_TRUE(read_ct("phantom:torso,dims=96x64x12").data == make_phantom("torso", grid_only).data);
}

}  // namespace
}  // namespace palp
