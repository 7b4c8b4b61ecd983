// A lumen's round outline (common/prep/vessel/vessel_outline.cpp) on tiny scenes built here, at
// 1.5 mm in-plane and the body axis along k: fat at -100 HU, soft tissue at 60 HU, contrast at
// 400 HU, cortex at 900 HU. The edge level is -20 HU (half way from the fat to the soft tissue),
// cortical HU 700. Expectations from the geometry: which voxel centres lie in which disk.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <functional>

#include "prep/vessel/vessel_outline.hpp"
#include "prep/vessel/vessel_segmentation.hpp"

namespace palp {
namespace {

constexpr double kSpacing = 1.5;
constexpr double kEdgeHu = -20.0;
constexpr double kCortexHu = 700.0;
constexpr double kCentre = 45.0;  // mm, in-plane centre of the scenes' vessel

struct Scene {
  CtVolume ct;
  Mask lumen, cortex;
};

// 60 x 60 voxels in-plane, 8 slices, all fat; `paint` gives each voxel's HU and whether it is in
// the lumen's mask from its in-plane position (mm).
Scene scene(const std::function<void(double x, double y, std::int16_t& hu, bool& lumen)>& paint) {
  Grid g;
  g.dims = {60, 60, 8};
  g.spacing = {kSpacing, kSpacing, kSpacing};
  Scene s{CtVolume(g, -100, "ct"), Mask(g, 0, "lumen"), Mask(g, 0, "cortex")};
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        std::int16_t hu = -100;
        bool in_lumen = false;
        paint(static_cast<double>(i) * kSpacing, static_cast<double>(j) * kSpacing, hu, in_lumen);
        s.ct.at(i, j, k) = hu;
        s.lumen.at(i, j, k) = in_lumen;
      }
  return s;
}

double from_centre(double x, double y) {
  return std::hypot(x - kCentre, y - kCentre);
}

// Voxels of `m` whose in-plane centre satisfies `where`.
std::int64_t count_where(const Mask& m, const std::function<bool(double x, double y)>& where,
                         bool set = true) {
  std::int64_t n = 0;
  for (std::int64_t k = 0; k < m.grid.dims[2]; ++k)
    for (std::int64_t j = 0; j < m.grid.dims[1]; ++j)
      for (std::int64_t i = 0; i < m.grid.dims[0]; ++i)
        n += (m.at(i, j, k) != 0) == set &&
             where(static_cast<double>(i) * kSpacing, static_cast<double>(j) * kSpacing);
  return n;
}

TEST(RoundOutline, TheFalseLumenOfADissectedAortaInFatIsTheVessels) {
  // An aorta 30 mm across in fat: a true lumen of contrast in its front half, a false lumen at
  // soft-tissue HU in its back half, a flap between them. The false lumen fills up to the wall.
  Scene s = scene([](double x, double y, std::int16_t& hu, bool& lumen) {
    if (from_centre(x, y) > 15.0) return;
    lumen = y < kCentre - 1.0;
    hu = lumen ? 400 : 60;
  });
  const std::int64_t false_lumen = count_where(
      s.lumen, [](double x, double y) { return from_centre(x, y) <= 13.5; }, false);
  ASSERT_GT(false_lumen, 8 * 100);
  const std::uint64_t added = fill_round_outlines(s.ct, s.cortex, kEdgeHu, kCortexHu, {}, s.lumen);
  EXPECT_GT(added, 0u);
  EXPECT_EQ(count_where(
                s.lumen, [](double x, double y) { return from_centre(x, y) <= 13.5; }, false),
            0);
  EXPECT_EQ(count_where(s.lumen, [](double x, double y) { return from_centre(x, y) > 15.0; }), 0);
  // Off, nothing moves.
  Scene off = scene([](double x, double y, std::int16_t& hu, bool& lumen) {
    if (from_centre(x, y) > 15.0) return;
    lumen = y < kCentre - 1.0;
    hu = lumen ? 400 : 60;
  });
  VesselParams no_outline;
  no_outline.outline_max_radius_mm = 0.0;
  EXPECT_EQ(fill_round_outlines(off.ct, off.cortex, kEdgeHu, kCortexHu, no_outline, off.lumen), 0u);
}

TEST(RoundOutline, AnOrganTheVesselRestsOnIsNotTaken) {
  // A dissected aorta 24 mm across (contrast in its front half, the false lumen at soft-tissue HU
  // behind) resting on an organ at the same soft-tissue HU that fills the scene behind it (from
  // 11 mm behind the aorta's centre on). The rays into the organ give no edge; the circle follows
  // the fat along the front and sides: the false lumen is filled, and no organ voxel more than a
  // voxel beyond the aorta's wall joins the lumen.
  Scene s = scene([](double x, double y, std::int16_t& hu, bool& lumen) {
    if (from_centre(x, y) <= 12.0) {
      lumen = y < kCentre - 1.0;
      hu = lumen ? 400 : 60;
    } else if (y >= kCentre + 11.0) {
      hu = 60;
    }
  });
  fill_round_outlines(s.ct, s.cortex, kEdgeHu, kCortexHu, {}, s.lumen);
  EXPECT_EQ(count_where(
                s.lumen, [](double x, double y) { return from_centre(x, y) <= 10.5; }, false),
            0);
  EXPECT_EQ(count_where(s.lumen, [](double x, double y) { return from_centre(x, y) > 13.5; }), 0);
}

TEST(RoundOutline, ACalcifiedFlapInsideTheLumenIsTheVessels) {
  // A ring of calcified intima (1200 HU, radius 9-10.5 mm) inside an aorta of contrast 30 mm
  // across, in fat: the rays go on through it; the ring is the lumen's, the fat is not.
  Scene s = scene([](double x, double y, std::int16_t& hu, bool& lumen) {
    const double r = from_centre(x, y);
    if (r > 15.0) return;
    const bool ring = r >= 9.0 && r <= 10.5;
    hu = ring ? 1200 : 400;
    lumen = !ring;
  });
  const auto ring = [](double x, double y) {
    return from_centre(x, y) >= 9.0 && from_centre(x, y) <= 10.5;
  };
  ASSERT_GT(count_where(s.lumen, ring, false), 8 * 30);
  fill_round_outlines(s.ct, s.cortex, kEdgeHu, kCortexHu, {}, s.lumen);
  EXPECT_EQ(count_where(s.lumen, ring, false), 0);
  EXPECT_EQ(count_where(s.lumen, [](double x, double y) { return from_centre(x, y) > 15.0; }), 0);
}

TEST(RoundOutline, AVertebraWhoseMarrowALumenSearchTookIsNotFilled) {
  // A vertebral body 30 mm across (a 2 mm cortex at 900 HU, marrow at 250 HU) in fat, with the
  // middle of its marrow (16 mm across, a quarter of it) in the lumen's mask, as a lumen search
  // that grew into it leaves it: every ray meets the cortex with fat behind it, an outline of
  // calcium. Nothing is added. Without its cortex (250 HU out to its edge) the same body is
  // filled: the cortex is what tells it from a vessel.
  const auto body = [](bool cortex) {
    return scene([cortex](double x, double y, std::int16_t& hu, bool& lumen) {
      const double r = from_centre(x, y);
      if (r > 15.0) return;
      hu = cortex && r >= 13.0 ? 900 : 250;
      lumen = r <= 8.0;
    });
  };
  Scene vertebra = body(true);
  EXPECT_EQ(
      fill_round_outlines(vertebra.ct, vertebra.cortex, kEdgeHu, kCortexHu, {}, vertebra.lumen),
      0u);
  Scene organ = body(false);
  EXPECT_GT(fill_round_outlines(organ.ct, organ.cortex, kEdgeHu, kCortexHu, {}, organ.lumen), 0u);
  EXPECT_EQ(count_where(
                organ.lumen, [](double x, double y) { return from_centre(x, y) <= 13.5; }, false),
            0);
}

TEST(RoundOutline, ALumenFillingLittleOfItsCircleIsNotFilled) {
  // A small lumen (9 mm across) in the middle of a round soft-tissue body 30 mm across in fat:
  // a vessel inside an organ, not an organ's vessel wall. It fills 9 % of the circle: nothing.
  Scene s = scene([](double x, double y, std::int16_t& hu, bool& lumen) {
    const double r = from_centre(x, y);
    if (r > 15.0) return;
    lumen = r <= 4.5;
    hu = lumen ? 400 : 60;
  });
  EXPECT_EQ(fill_round_outlines(s.ct, s.cortex, kEdgeHu, kCortexHu, {}, s.lumen), 0u);
}

}  // namespace
}  // namespace palp
