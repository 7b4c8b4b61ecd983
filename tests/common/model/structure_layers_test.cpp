// Structure layers (model/structure_layers.hpp): the pulse waveform against the shape physiology
// gives an arterial pressure pulse, Flamant's strip integral against a numeric integration of the
// point kernel, the pulse at the fingertip against the pressure arithmetic and the measured range
// of human pulses, and the layers in a tick over a tiny analytic scene: a flat skin, a straight
// artery 15 mm under it, an organ slab 20 mm under it.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>

#include "base/errors.hpp"
#include "model/force_model.hpp"
#include "prep/maps/distance_transform.hpp"
#include "support/linear_map.hpp"

namespace palp {
namespace {

constexpr double kZ0 = 20.25;  // the skin plane (body below)
constexpr double kCx = 50.0, kCy = 20.0;
const Index3 kDims{101, 41, 41};

ForceParams palp() {
  return palp_params(ToolKind::Finger);
}

// Flamant's kernel for a line load at depth h: the vertical stress share per mm across the
// surface, 2 h^3 / (pi (x^2 + h^2)^2), integrated numerically (midpoint, 20000 steps).
double flamant_numeric(double h, double lateral, double width) {
  const int n = 20000;
  const double a = lateral - width / 2, dx = width / n;
  double sum = 0.0;
  for (int i = 0; i < n; ++i) {
    const double x = a + (i + 0.5) * dx;
    sum += 2 * h * h * h / (std::numbers::pi * (x * x + h * h) * (x * x + h * h)) * dx;
  }
  return sum;
}

TEST(PulseWaveform, HasTheShapeOfAnArterialPressurePulse) {
  // Sampled at 0.1 % of a beat (0.83 ms at 72 bpm).
  const int n = 1000;
  std::vector<double> w(n);
  for (int i = 0; i < n; ++i) w[i] = pulse_waveform(static_cast<double>(i) / n);
  EXPECT_EQ(pulse_waveform(0.0), 0.0);  // the foot: end diastole
  int peak = 0;
  for (int i = 0; i < n; ++i) {
    EXPECT_GE(w[i], 0.0);
    EXPECT_LE(w[i], 1.0);
    if (w[i] > w[peak]) peak = i;
  }
  EXPECT_NEAR(w[peak], 1.0, 1e-3);
  // Systolic peak 100-170 ms after the foot at 72 bpm (833 ms a beat): 0.12-0.20 of the beat.
  EXPECT_GE(peak, 120);
  EXPECT_LE(peak, 200);
  // The dicrotic notch: a local minimum after the peak, then a local maximum (the dicrotic wave),
  // at the end of ejection (300-400 ms at 72 bpm: 0.36-0.48 of the beat).
  int notch = -1, dicrotic = -1;
  for (int i = peak + 1; i + 1 < n; ++i) {
    if (notch < 0 && w[i] < w[i - 1] && w[i] <= w[i + 1]) notch = i;
    if (notch >= 0 && w[i] > w[i - 1] && w[i] >= w[i + 1]) {
      dicrotic = i;
      break;
    }
  }
  ASSERT_GE(notch, 0);
  ASSERT_GT(dicrotic, notch);
  EXPECT_GE(notch, 360);
  EXPECT_LE(notch, 480);
  EXPECT_LT(w[dicrotic], w[peak]);
  // The upstroke is steeper than any fall, and the beat wraps without a jump.
  double rise = 0.0, fall = 0.0;
  for (int i = 1; i < n; ++i) {
    rise = std::max(rise, w[i] - w[i - 1]);
    fall = std::max(fall, w[i - 1] - w[i]);
  }
  EXPECT_GT(rise, 1.5 * fall);
  EXPECT_NEAR(pulse_waveform(1.0 - 1e-9), pulse_waveform(0.0), 1e-3);
  EXPECT_NEAR(pulse_waveform(2.3), pulse_waveform(0.3), 1e-12);
  EXPECT_EQ(pulse_waveform(std::nan("")), 0.0);
}

TEST(StripTransmission, IsFlamantsKernelIntegratedOverTheStrip) {
  for (double h : {2.0, 10.0, 15.0, 40.0})
    for (double lateral : {0.0, 8.0, 16.0, -16.0})
      EXPECT_NEAR(strip_transmission(h, lateral, 16.0), flamant_numeric(h, lateral, 16.0), 1e-6)
          << h << " " << lateral;
  EXPECT_NEAR(strip_transmission(1e-6, 3.0, 16.0), 1.0, 1e-6);   // a load at the surface, under it
  EXPECT_NEAR(strip_transmission(1e-6, 30.0, 16.0), 0.0, 1e-6);  // beside the strip
  // Two adjacent strips carry what the strip of both widths carries.
  EXPECT_NEAR(strip_transmission(12.0, -4.0, 8.0) + strip_transmission(12.0, 4.0, 8.0),
              strip_transmission(12.0, 0.0, 16.0), 1e-12);
}

TEST(PulseForce, IsThePressureAboveDiastoleOverTheVesselThroughTheTissue) {
  const ForceParams p = palp();
  const double mmHg = 133.322e-6;  // N/mm^2
  const double T = flamant_numeric(12.0, 0.0, p.pad_mm);
  // A light touch: the whole pulse pressure (systolic - diastolic) on the vessel's width.
  EXPECT_NEAR(
      pulse_amplitude(p, 12.0, 0.0, 0.0),
      (p.pulse_systolic_mmHg - p.pulse_diastolic_mmHg) * mmHg * p.pulse_vessel_mm * p.pad_mm * T,
      1e-6);
  EXPECT_EQ(pulse_force(p, 12.0, 0.0, 0.0, 0.0), 0.0);  // at end diastole nothing
  // The finger's pressure at the vessel halfway between diastolic and systolic: half the pulse.
  const double half = (p.pulse_diastolic_mmHg + p.pulse_systolic_mmHg) / 2 * mmHg;
  const double press = half / T * p.pad_mm * p.pad_mm;
  EXPECT_NEAR(pulse_amplitude(p, 12.0, 0.0, press), 0.5 * pulse_amplitude(p, 12.0, 0.0, 0.0), 1e-6);
  // At systolic the lumen stays shut: occluded.
  EXPECT_EQ(
      pulse_amplitude(p, 12.0, 0.0, 1.001 * p.pulse_systolic_mmHg * mmHg / T * p.pad_mm * p.pad_mm),
      0.0);
  // Fading with depth and with lateral offset.
  EXPECT_LT(pulse_amplitude(p, 20.0, 0.0, 0.0), pulse_amplitude(p, 10.0, 0.0, 0.0));
  EXPECT_LT(pulse_amplitude(p, 12.0, 16.0, 0.0), 0.5 * pulse_amplitude(p, 12.0, 0.0, 0.0));
}

// The femoral artery under 10-20 mm of tissue, pressed with 2-5 N (the skin law's depth for that
// force taken off): every amplitude within the human radial pulse's measured range, 0.02-0.5 N
// (Subudhi et al., IEEE ToH 2025), and none when the press closes the vessel.
TEST(PulseForce, DefaultsGiveHumanAmplitudesOverASuperficialArtery) {
  const ForceParams p = palp();
  auto indentation = [](double force) {  // the skin law's inverse (bisection)
    double lo = 0.0, hi = 30.0;
    for (int i = 0; i < 100; ++i) {
      const double mid = 0.5 * (lo + hi);
      (surface_force(mid) < force ? lo : hi) = mid;
    }
    return lo;
  };
  for (double tissue : {10.0, 15.0, 20.0}) {
    const double vessel_depth = tissue + 4.0;  // a femoral artery 8 mm across
    for (double press : {2.0, 3.5, 5.0}) {
      const double a = pulse_amplitude(p, vessel_depth - indentation(press), 0.0, press);
      EXPECT_GE(a, 0.02) << tissue << " mm, " << press << " N";
      EXPECT_LE(a, 0.5) << tissue << " mm, " << press << " N";
    }
    EXPECT_EQ(pulse_amplitude(p, vessel_depth - indentation(15.0), 0.0, 15.0), 0.0);
  }
}

TEST(OrganForce, IsANonLinearSpringOnTheBordersReach) {
  ForceParams p = palp();
  double slope = -1.0;
  EXPECT_EQ(organ_force(p, p.organ_reach_mm + 1.0, &slope), 0.0);
  EXPECT_EQ(slope, 0.0);
  const double c = 10.0;
  EXPECT_NEAR(organ_force(p, p.organ_reach_mm - c, &slope), p.organ_k1 * c + p.organ_k3 * c * c * c,
              1e-12);
  EXPECT_NEAR(slope, p.organ_k1 + 3 * p.organ_k3 * c * c, 1e-12);
  EXPECT_EQ(organ_force(p, -100.0), p.organ_fmax);  // capped deep inside
}

TEST(ForceParams, LayerParametersAreBoundedByName) {
  ForceParams p = palp();
  set_param(p, "pulse_bpm", 0.0);
  EXPECT_EQ(p.pulse_bpm, 0.0);
  EXPECT_THROW(set_param(p, "pulse_bpm", 300.0), UsageError);
  EXPECT_THROW(set_param(p, "pulse_diastolic_mmHg", 130.0), UsageError);  // above systolic
  EXPECT_THROW(set_param(p, "organ_k3", -1.0), UsageError);
  set_param(p, "pad_mm", 12.0);
  EXPECT_EQ(p.pad_mm, 12.0);
}

// --- the layers in a tick ---------------------------------------------------------------------

constexpr double kArteryZ = kZ0 - 15.0;  // centre line along y at x = kCx, 15 mm under the skin

DistanceMap artery_map(double radius) {
  Grid g;
  g.dims = kDims;
  DistanceMap m(g, 0.0f);
  for (std::int64_t k = 0; k < kDims[2]; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = 0; i < kDims[0]; ++i)
        m.at(i, j, k) = static_cast<float>(radius - std::hypot(i - kCx, k - kArteryZ));
  return m;
}

std::shared_ptr<const FieldSampler> skin_only() {
  return std::make_shared<const FieldSampler>(test::linear_map(kDims, {0, 0, -1}, kZ0));
}

StructureLayer layer(const char* name, LayerKind kind, DistanceMap map) {
  return {name, kind,
          std::make_shared<const FieldSampler>(
              std::move(map), SamplerConfig{GradientScheme::AnalyticTrilinear, Storage::Float32})};
}

// finger:1's pad `depth` mm under the skin at x.
Pose press(double depth, double x = kCx) {
  return Pose{{x, kCy, kZ0 + 8.0 - depth}, Quat{}};
}

struct Beat {
  double peak = 0.0;      // largest |f_pulse| (N)
  double period_s = 0.0;  // between the last two upstrokes through half the peak
};

// 3 s of ticks at 1 kHz, held still at `depth`, x.
Beat hold(const Model& model, double depth, double x = kCx) {
  State st = make_state(model);
  std::vector<double> f;
  for (int n = 0; n <= 3000; ++n) {
    tick(model, st, press(depth, x), 1e-3 * n);
    f.push_back(st.f_pulse.z);
  }
  Beat beat;
  for (double v : f) beat.peak = std::max(beat.peak, std::fabs(v));
  double last = -1.0;
  for (std::size_t n = 1; n < f.size(); ++n) {
    if (f[n - 1] < 0.5 * beat.peak && f[n] >= 0.5 * beat.peak) {
      if (last >= 0.0) beat.period_s = 1e-3 * static_cast<double>(n) - last;
      last = 1e-3 * static_cast<double>(n);
    }
  }
  return beat;
}

TEST(StructureLayers, AnArteryPulsesAtTheSetRateWithTheLawsAmplitude) {
  const ForceParams p = palp();
  const Model model(skin_only(), parse_tool("finger:1"), p,
                    {layer("artery", LayerKind::Artery, artery_map(p.pulse_vessel_mm / 2))});
  const double depth = 4.0;
  const Beat b = hold(model, depth);
  EXPECT_NEAR(b.period_s, 60.0 / 72.0, 2e-3);
  // The skin's press at that depth and the vessel's centre 15 - depth mm below the pad.
  const double expected = pulse_amplitude(p, 15.0 - depth, 0.0, surface_force(depth));
  EXPECT_NEAR(b.peak, expected, 0.01 * expected);
  EXPECT_GT(b.peak, 0.02);
  // Off the vessel it fades; pressed hard it is occluded; at 0 bpm it stands still.
  EXPECT_LT(hold(model, depth, kCx + 16.0).peak, 0.3 * b.peak);
  EXPECT_EQ(hold(model, 9.0).peak, 0.0);
  ForceParams still = p;
  still.pulse_bpm = 0.0;
  const Model no_pulse(skin_only(), parse_tool("finger:1"), still,
                       {layer("artery", LayerKind::Artery, artery_map(still.pulse_vessel_mm / 2))});
  EXPECT_EQ(hold(no_pulse, depth).peak, 0.0);
}

TEST(StructureLayers, ThePulseIsPartOfTheDeviceForceAndTheClockIsTheCallersTime) {
  const ForceParams p = palp();
  const Model with(skin_only(), parse_tool("finger:1"), p,
                   {layer("artery", LayerKind::Artery, artery_map(p.pulse_vessel_mm / 2))});
  const Model without(skin_only(), parse_tool("finger:1"), p);
  State a = make_state(with), b = make_state(without);
  for (double t : {0.0, 0.05, 0.117, 0.2, 0.2, 0.1, 0.35}) {  // a repeated and a backward time
    tick(with, a, press(4.0), t);
    tick(without, b, press(4.0), t);
    EXPECT_NEAR(a.f_device.z, b.f_device.z + a.f_pulse.z, 1e-12);
    EXPECT_EQ(b.f_pulse.z, 0.0);
  }
  EXPECT_NEAR(a.pulse_phase, 0.35 * 72.0 / 60.0, 1e-12);  // the step back held the phase
}

TEST(StructureLayers, ThePaperModelIgnoresLayersBitForBit) {
  const ForceParams p = default_params(ToolKind::Finger);
  const Model with(skin_only(), parse_tool("finger:7"), p,
                   {layer("artery", LayerKind::Artery, artery_map(3.5)),
                    layer("liver", LayerKind::Organ, test::linear_map(kDims, {0, 0, -1}, 0.25))});
  const Model without(skin_only(), parse_tool("finger:7"), p);
  State a = make_state(with), b = make_state(without);
  for (int n = 0; n < 500; ++n) {
    const Pose pose = press(1.0 + 0.01 * n, kCx + 0.02 * n);
    tick(with, a, pose, 1e-3 * n);
    tick(without, b, pose, 1e-3 * n);
    ASSERT_EQ(a.f_device.x, b.f_device.x);
    ASSERT_EQ(a.f_device.y, b.f_device.y);
    ASSERT_EQ(a.f_device.z, b.f_device.z);
  }
}

TEST(StructureLayers, AnOrganBeneathAddsItsBorderSpringAndItsEdgeIsFelt) {
  const ForceParams p = palp();
  // The organ: below z = 0.25 (20 mm under the skin) for x < 50 only, as a mask's distance.
  Grid g;
  g.dims = kDims;
  Mask organ(g, 0);
  for (std::int64_t k = 0; k <= 0; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = 0; i < 50; ++i) organ.at(i, j, k) = 1;
  const Model model(skin_only(), parse_tool("finger:1"), p,
                    {layer("liver", LayerKind::Organ, signed_distance(organ))});
  const Model plain(skin_only(), parse_tool("finger:1"), p);
  auto normal_force = [&](const Model& m, double x) {
    State st = make_state(m);
    tick(m, st, press(6.0, x), 0.0);
    return st.f_device.z;
  };
  // Over the organ, 6 mm in: the organ's face (voxel row 0 reaches z = 0.5) is 13.75 mm below the
  // pad.
  const double over = normal_force(model, 20.0) - normal_force(plain, 20.0);
  EXPECT_NEAR(over, organ_force(p, 13.75), 0.02 * organ_force(p, 13.75));
  EXPECT_GT(over, 1.0);
  // Past its edge nothing: the edge is where the force falls.
  EXPECT_NEAR(normal_force(model, 90.0), normal_force(plain, 90.0), 1e-9);
}

}  // namespace
}  // namespace palp
