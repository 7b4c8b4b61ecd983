// The torso phantom: its anatomy as painted layers (body wall, ribs, organs, vessels, spine, arms,
// implant, CT table) and the row-by-row drawing with partial-volume blending, metal streaks,
// noise and the truth masks (see phantom.hpp for what it shows and its options).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <optional>
#include <variant>
#include <vector>

#include "base/parallel.hpp"
#include "io/phantom_paint.hpp"
#include "io/phantom_torso_anatomy.hpp"

namespace palp::phantom_detail {

Tissue vessel_tissue(bool artery, double hu) {
  const bool contrast = hu >= kSoftTissueHu + kContrastAboveTissueHu;
  if (artery) return contrast ? Tissue::kArteryContrast : Tissue::kArteryPlain;
  return contrast ? Tissue::kVeinContrast : Tissue::kVeinPlain;
}

TorsoLevels torso_levels(const PhantomOptions& o) {
  TorsoLevels l;
  if (!o.contrast && !o.aorta_hu) return l;
  l.tree = true;
  switch (o.contrast.value_or(PhantomContrast::arterial)) {
    case PhantomContrast::none:
      l = {true, 55.0, 35.0, 40.0, 40.0, 40.0, 40.0, 40.0};
      break;
    case PhantomContrast::arterial:  // veins barely enhanced, the infrarenal IVC not at all
      l = {true, 60.0, 150.0, 400.0, 85.0, 40.0, 90.0, 95.0};
      break;
    case PhantomContrast::portal_venous:
      l = {true, 100.0, 160.0, 170.0, 150.0, 130.0, 180.0, 160.0};
      break;
  }
  if (o.aorta_hu) l.artery = *o.aorta_hu;
  return l;
}

namespace {

void add_body_wall(std::vector<Layer>& layers) {
  const auto ring = [](double inset) {
    return EllipticCylinder{kBodyCx, kBodyCy, kBodyA - inset, kBodyB - inset};
  };
  layers.push_back({ring(0.0), 30.0, Tissue::kPatient});            // skin
  layers.push_back({ring(2.0), -100.0, Tissue::kPatient});          // subcutaneous fat
  layers.push_back({ring(17.0), 50.0, Tissue::kPatient});           // muscle wall
  layers.push_back({ring(29.0), kSoftTissueHu, Tissue::kPatient});  // abdominal cavity
}

void add_ribs(std::vector<Layer>& layers) {
  const double ar = kBodyA - 23.0, br = kBodyB - 23.0;  // ring inside the muscle wall
  const double t0 = -55.0 * std::numbers::pi / 180.0, t1 = 65.0 * std::numbers::pi / 180.0;
  for (double z = -22.0; z <= 88.0; z += 22.0) {
    const RibPair cortex{kBodyCx, kBodyCy, ar, br, t0, t1, z, 20.0, 3.0, 4.5, 0.0};
    RibPair marrow = cortex;
    marrow.radial = 1.6;
    marrow.height = 3.0;
    marrow.trim = 3.0;
    layers.push_back({cortex, 900.0, Tissue::kBone});
    layers.push_back({marrow, 250.0, Tissue::kBone});
  }
}

// A dissected aorta (options.dissection) from z_lo up: periaortic fat 4 mm around it (painted
// first, so the veins crossing it cover it), then the vessel filled by the false lumen at
// soft-tissue HU + 10 with the true lumen, 14 mm across, in its front at the aorta's HU. Both are
// the aorta's lumen (the truth vessel).
void add_periaortic_fat(std::vector<Layer>& layers, double z_lo) {
  layers.push_back(
      {EllipticCylinder{kAortaCx, kAortaCy, kAortaR + 4.0, kAortaR + 4.0, z_lo, kInfinity}, -100.0,
       Tissue::kPatient});
}
void add_dissected_aorta(std::vector<Layer>& layers, double hu, double z_lo) {
  layers.push_back({EllipticCylinder{kAortaCx, kAortaCy, kAortaR, kAortaR, z_lo, kInfinity},
                    kSoftTissueHu + 10.0, Tissue::kArteryContrast});
  layers.push_back({EllipticCylinder{kAortaCx, kAortaCy - 4.0, 7.0, 7.0, z_lo, kInfinity}, hu,
                    vessel_tissue(true, hu)});
}

// With contrast options: the aorta down to its bifurcation, the common iliac arteries, the coeliac
// trunk and superior mesenteric artery leaving it forward, the renal arteries into the kidneys'
// hila, and the veins (inferior vena cava right of the aorta, the renal veins, the left one
// between the aorta and the SMA, the portal vein up into the liver). Veins first: an artery that
// crosses one covers it.
void add_vessel_tree(std::vector<Layer>& layers, const TorsoLevels& l, bool dissection) {
  if (dissection) add_periaortic_fat(layers, kAortaBifurcationZ);
  const auto vein = [&](const Shape& s, double hu) {
    layers.push_back({s, hu, vessel_tissue(false, hu)});
  };
  vein(EllipticCylinder{kBodyCx - 20.0, kBodyCy + 12.0, 11.0, 8.0, -84.0, -14.0}, l.ivc_lower);
  vein(EllipticCylinder{kBodyCx - 20.0, kBodyCy + 12.0, 11.0, 8.0, -14.0, kInfinity}, l.ivc_upper);
  vein(Tube{{-17.0, 6.0, -11.0}, {0.0, -6.0, -9.0}, 4.5}, l.renal_vein);   // right
  vein(Tube{{56.0, 2.0, -10.0}, {34.0, -20.0, -7.0}, 4.0}, l.renal_vein);  // left, from the hilum
  vein(Tube{{34.0, -20.0, -7.0}, {6.0, -10.0, -8.0}, 4.0}, l.renal_vein);  // in front of the aorta
  vein(Tube{{14.0, -26.0, 4.0}, {-22.0, -38.0, 32.0}, 6.5}, l.portal);     // into the liver
  const Tissue artery = vessel_tissue(true, l.artery);
  const auto add = [&](const Shape& s) { layers.push_back({s, l.artery, artery}); };
  if (dissection)
    add_dissected_aorta(layers, l.artery, kAortaBifurcationZ);
  else
    add(EllipticCylinder{kAortaCx, kAortaCy, kAortaR, kAortaR, kAortaBifurcationZ, kInfinity});
  add(common_iliac(1.0));
  add(common_iliac(-1.0));
  add(Tube{{kAortaCx, -6.0, 32.0}, {24.0, -42.0, 36.0}, 3.5});   // coeliac trunk
  add(Tube{{kAortaCx, -6.0, 16.0}, {28.0, -46.0, -18.0}, 4.0});  // superior mesenteric
  add(Tube{{24.0, 3.0, -16.0}, {-16.0, 10.0, -22.0}, 3.0});      // right renal
  add(Tube{{36.0, 3.0, -16.0}, {54.0, 9.0, -20.0}, 3.0});        // left renal
}

void add_organs(std::vector<Layer>& layers, const TorsoLevels& levels, bool structures,
                bool dissection) {
  layers.push_back({Ellipsoid{{kBodyCx - 50.0, kBodyCy - 5.0, 10.0}, {55.0, 55.0, 50.0}},
                    levels.liver, Tissue::kLiver});  // liver
  for (double side : {-1.0, 1.0}) {                  // kidneys
    layers.push_back({Ellipsoid{{kBodyCx + side * 55.0, kBodyCy + 35.0, -20.0}, {25.0, 18.0, 45.0}},
                      levels.kidney, Tissue::kPatient});
  }
  // Lungs: domes whose bases sit above the liver and which run out through the top slice.
  layers.push_back({Ellipsoid{{kBodyCx - 70.0, kBodyCy + 5.0, 40.0 + 160.0}, {42.0, 52.0, 160.0}},
                    -850.0, Tissue::kPatient});
  layers.push_back({Ellipsoid{{kBodyCx + 70.0, kBodyCy + 5.0, 25.0 + 160.0}, {42.0, 52.0, 160.0}},
                    -850.0, Tissue::kPatient});
  // Bowel gas in the lower abdomen; the last pocket crosses the bottom slice.
  const std::array<std::array<double, 6>, 5> pockets{{{30, -45, -40, 22, 14, 18},
                                                      {-20, -50, -70, 18, 12, 15},
                                                      {60, -30, -75, 15, 10, 14},
                                                      {-60, -35, -50, 14, 10, 12},
                                                      {5, -40, -100, 20, 12, 16}}};
  for (const auto& p : pockets) {
    layers.push_back({Ellipsoid{{kBodyCx + p[0], kBodyCy + p[1], p[2]}, {p[3], p[4], p[5]}}, kAirHu,
                      Tissue::kPatient});
  }
  if (structures) add_liver_edge(layers, levels);
  if (levels.tree) {
    add_vessel_tree(layers, levels, dissection);
  } else if (dissection) {  // (with structures it needs the tree: check_options)
    add_periaortic_fat(layers, -kInfinity);
    add_dissected_aorta(layers, levels.artery, -kInfinity);
  } else if (structures) {
    add_aorta_to_bifurcation(layers, levels);
  } else {
    // Contrast-filled aorta, pressed against the front of the vertebral bodies.
    layers.push_back({EllipticCylinder{kAortaCx, kAortaCy, kAortaR, kAortaR}, levels.artery,
                      vessel_tissue(true, levels.artery)});
  }
  if (structures) add_groin_vessels(layers, levels);
}

void add_spine(std::vector<Layer>& layers, double z_lo, double z_hi) {
  layers.push_back({EllipticCylinder{kBodyCx, kSpineCy, 22.0, 16.0}, 80.0, Tissue::kPatient});
  const long first = static_cast<long>(std::floor(z_lo / kVertebraPeriod)) - 1;
  const long last = static_cast<long>(std::ceil(z_hi / kVertebraPeriod)) + 1;
  for (long n = first; n <= last; ++n) {
    const double z = static_cast<double>(n) * kVertebraPeriod + 8.0;
    layers.push_back({EllipticCylinder{kBodyCx, kSpineCy, 22.0, 16.0, z - 12.5, z + 12.5}, 900.0,
                      Tissue::kBone});  // vertebral body cortex and endplates
    layers.push_back({EllipticCylinder{kBodyCx, kSpineCy, 20.0, 14.0, z - 10.5, z + 10.5}, 250.0,
                      Tissue::kBone});  // marrow
    layers.push_back({EllipticCylinder{kBodyCx, kCanalCy, 15.0, 13.0, z - 11.0, z + 9.0}, 700.0,
                      Tissue::kBone});  // arch
    layers.push_back(
        {Box{kBodyCx - 4.0, kBodyCx + 4.0, kCanalCy + 9.0, kCanalCy + 21.0, z - 9.0, z + 5.0},
         700.0, Tissue::kBone});  // spinous process
    layers.push_back(
        {Box{kBodyCx - 36.0, kBodyCx + 36.0, kCanalCy - 7.0, kCanalCy + 1.0, z - 6.0, z + 2.0},
         700.0, Tissue::kBone});  // transverse processes
  }
  layers.push_back({EllipticCylinder{kBodyCx, kCanalCy, 8.0, 8.0}, 20.0, Tissue::kPatient});
}

// The brachial artery with the vessel tree: anteromedial to the humerus, with 1 mm of tissue
// between its wall and the humerus's cortex (closer than it mostly lies; as the subclavian rests
// on the first rib): a branch that both of the scan's ends cut off from its trunk, on bone.
constexpr double kBrachialR = 3.0, kBrachialFromHumerus = 11.0 + 1.0 + kBrachialR;

// side -1: the patient's right arm (the default one), +1: the left, its mirror image about the
// body's centre.
void add_arm(std::vector<Layer>& layers, double side, const TorsoLevels& levels) {
  const double cx = side < 0.0 ? -158.0 : 2.0 * kBodyCx + 158.0, cy = kPadTop - 40.0;
  layers.push_back({EllipticCylinder{cx, cy, 38.0, 40.0}, 30.0, Tissue::kPatient});
  layers.push_back({EllipticCylinder{cx, cy, 36.0, 38.0}, -100.0, Tissue::kPatient});
  layers.push_back({EllipticCylinder{cx, cy, 30.0, 32.0}, 50.0, Tissue::kPatient});
  layers.push_back({EllipticCylinder{cx, cy - 3.0, 11.0, 11.0}, 900.0, Tissue::kBone});
  layers.push_back({EllipticCylinder{cx, cy - 3.0, 8.0, 8.0}, 120.0, Tissue::kBone});
  if (!levels.tree) return;
  const double medial = side < 0.0 ? 1.0 : -1.0, d = kBrachialFromHumerus / std::sqrt(2.0);
  layers.push_back({EllipticCylinder{cx + medial * d, cy - 3.0 - d, kBrachialR, kBrachialR},
                    levels.artery, vessel_tissue(true, levels.artery)});
}

// A pair of pedicle screws in the vertebra at kScrewZ: from behind the transverse processes,
// lateral to the canal, through the pedicles into the vertebral body (3 mm radius, 3500 HU).
constexpr double kScrewHu = 3500.0, kScrewR = 3.0;
Tube screw(double side) {
  return {{kBodyCx + side * 28.0, kCanalCy + 13.0, kScrewZ},
          {kBodyCx + side * 7.0, kSpineCy - 9.0, kScrewZ},
          kScrewR};
}

void add_table(std::vector<Layer>& layers) {
  layers.push_back({Box{-kInfinity, kInfinity, kPadTop + 20.0, kPadTop + 29.0}, 300.0,
                    Tissue::kEquipment});  // carbon board across the whole field of view
  layers.push_back(
      {Box{-225.0, 225.0, kPadTop, kPadTop + 20.0}, -100.0, Tissue::kEquipment});  // gel pad
  layers.push_back({EllipticCylinder{kBodyCx + 115.0, kPadTop - 2.5, 2.5, 2.5}, 200.0,
                    Tissue::kEquipment});  // cable lying on the pad
}

// Paint order: later layers cover earlier ones.
std::vector<Layer> torso_layers(const PhantomOptions& options, double z_lo, double z_hi) {
  std::vector<Layer> layers;
  add_table(layers);
  add_body_wall(layers);
  add_ribs(layers);
  const TorsoLevels levels = torso_levels(options);
  add_organs(layers, levels, options.structures, options.dissection);
  add_spine(layers, z_lo, z_hi);
  if (options.metal)
    for (double side : {-1.0, 1.0}) layers.push_back({screw(side), kScrewHu, Tissue::kMetal});
  if (options.arms >= 1) add_arm(layers, -1.0, levels);
  if (options.arms >= 2) add_arm(layers, 1.0, levels);
  return layers;
}

// ---------------------------------------------------------------------------------------------
// Metal streaks: in the slices through the screws, bright and dark streaks radiate from each
// screw's middle in the axial plane (fixed angles and amplitudes of 300-800 HU, about 1.5 mm
// wide, halving every ~40 mm), and a dark band joins the two screws, as beam hardening and photon
// starvation draw them. Added to the patient's voxels only (not the air, the table or the metal).

struct Streaks {
  std::array<std::array<double, 2>, 2> sources{};  // the screws' middles (x, y)

  double hu(double x, double y, double z, double hz) const {
    const double fz = coverage_from(kScrewR - std::abs(z - kScrewZ), hz);
    if (fz <= 0.0) return 0.0;
    constexpr std::array<double, 10> kAmplitude{800,  -600, 500,  -700, 300,
                                                -400, 650,  -500, 450,  -800};
    constexpr double kWidth = 1.5, kDecay = 60.0;
    double sum = 0.0;
    for (std::size_t s = 0; s < sources.size(); ++s) {
      const double dx = x - sources[s][0], dy = y - sources[s][1];
      for (std::size_t m = 0; m < kAmplitude.size(); ++m) {
        const double angle = (36.0 * static_cast<double>(m) + 7.0 + 13.0 * static_cast<double>(s)) *
                             std::numbers::pi / 180.0;
        const double along = dx * std::cos(angle) + dy * std::sin(angle);
        if (along < kScrewR) continue;
        const double across = -dx * std::sin(angle) + dy * std::cos(angle);
        sum += kAmplitude[m] * std::exp(-(across * across) / (kWidth * kWidth) - along / kDecay);
      }
    }
    // the dark band between the two screws
    const double bx = sources[1][0] - sources[0][0], by = sources[1][1] - sources[0][1];
    const double len = std::hypot(bx, by);
    const double t = ((x - sources[0][0]) * bx + (y - sources[0][1]) * by) / (len * len);
    if (t > 0.0 && t < 1.0) {
      const double across = std::abs((x - sources[0][0]) * by - (y - sources[0][1]) * bx) / len;
      sum -= 700.0 * std::exp(-(across * across) / 9.0);
    }
    return fz * std::clamp(sum, -800.0, 800.0);
  }
};

std::optional<Streaks> torso_streaks(const PhantomOptions& options) {
  if (!options.metal) return std::nullopt;
  Streaks s;
  for (int n = 0; n < 2; ++n) {
    const Tube t = screw(n == 0 ? -1.0 : 1.0);
    s.sources[n] = {(t.a[0] + t.b[0]) / 2.0, (t.a[1] + t.b[1]) / 2.0};
  }
  return s;
}

bool takes_streaks(Tissue t) {
  return t != Tissue::kOutside && t != Tissue::kEquipment && t != Tissue::kMetal;
}

// Puts the torso in the middle of the grid (its z = `level` at the grid's centre), with the pad's
// top face snapped halfway between two voxel rows so that neither the back nor the pad shares a
// voxel with the other.
AnatomyFrame torso_frame(const Grid& grid, double level) {
  AnatomyFrame f{grid_centre(grid), fit_scale(grid, kTorsoReferenceFov, 2), grid.spacing};
  f.centre[2] -= level * f.scale;
  const double pad_top = f.centre[1] + kPadTop * f.scale;
  const double snapped = (std::round(pad_top / grid.spacing[1] - 0.5) + 0.5) * grid.spacing[1];
  f.centre[1] += snapped - pad_top;
  return f;
}

void add_streaks(const Streaks& streaks, const RowContext& row, const AnatomyFrame& frame,
                 RowBuffers& buf) {
  for (std::size_t i = 0; i < buf.hu.size(); ++i) {
    if (!takes_streaks(buf.tissue[i])) continue;
    const double x = frame.coord(0, static_cast<std::int64_t>(i));
    buf.hu[i] += streaks.hu(x, row.y, row.z, row.h[2]);
  }
}

}  // namespace

CtVolume draw_torso(const Grid& grid, const PhantomOptions& options, PhantomTruth* truth) {
  const AnatomyFrame frame = torso_frame(grid, options.level_mm);
  const double z_lo = frame.coord(2, 0), z_hi = frame.coord(2, grid.dims[2] - 1);
  const std::vector<Layer> layers = torso_layers(options, z_lo, z_hi);
  const std::optional<Streaks> streaks = torso_streaks(options);
  CtVolume ct(grid, 0, "torso phantom");
  if (truth) *truth = empty_truth(grid, "torso truth");
  const std::int64_t nx = grid.dims[0], ny = grid.dims[1];
  parallel_for_chunks(grid.dims[2], 1, [&](std::int64_t k_begin, std::int64_t k_end) {
    RowBuffers buf{std::vector<double>(nx), std::vector<Tissue>(nx), {}};
    for (std::int64_t k = k_begin; k < k_end; ++k) {
      for (std::int64_t j = 0; j < ny; ++j) {
        std::fill(buf.hu.begin(), buf.hu.end(), kAirHu);
        std::fill(buf.tissue.begin(), buf.tissue.end(), Tissue::kOutside);
        const RowContext row{frame.coord(1, j), frame.coord(2, k), frame.voxel_size()};
        for (const Layer& layer : layers) {
          std::visit(
              [&](const auto& s) {
                paint_shape_row(s, layer.hu, layer.tissue, 0, row, frame, buf);
              },
              layer.shape);
        }
        if (streaks) add_streaks(*streaks, row, frame, buf);
        const std::size_t base = grid.linear(0, j, k);
        for (std::int64_t i = 0; i < nx; ++i)
          ct.data[base + i] = to_hu(buf.hu[i] + noise_hu(i, j, k));
        if (truth) write_truth(buf, base, *truth);
      }
    }
  });
  return ct;
}

}  // namespace palp::phantom_detail
