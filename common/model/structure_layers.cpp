#include "model/structure_layers.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

#include "base/errors.hpp"
#include "model/force_model.hpp"

namespace palp {
namespace {

// The waves of one beat (phase units): the percussion wave of the ventricle's ejection, the tidal
// wave reflected from the periphery, and the dicrotic wave after the aortic valve closes; from the
// dicrotic wave on, the windkessel's exponential run-off to the next beat's foot.
// The percussion wave rises faster than it falls (the ejection's upstroke); the tidal wave makes
// the late-systolic shoulder; the notch falls between it and the dicrotic wave.
struct Wave {
  double centre, rise_width, fall_width, height;
};
constexpr std::array<Wave, 3> kWaves{
    {{0.13, 0.035, 0.06, 1.0}, {0.26, 0.08, 0.08, 0.6}, {0.47, 0.04, 0.04, 0.3}}};
constexpr double kRunOffStart = 0.47;  // the dicrotic wave's crest
constexpr double kRunOffTau = 0.20;    // the run-off's time constant (beats)
constexpr int kTable = 1024;

double waves(double phase) {
  double sum = 0.0;
  for (const Wave& w : kWaves) {
    const double d = (phase - w.centre) / (phase < w.centre ? w.rise_width : w.fall_width);
    sum += w.height * std::exp(-0.5 * d * d);
  }
  return sum;
}

// Unnormalised: the waves, less their (small) value at the foot blended out by the crest, so the
// beat starts at 0; past the crest the run-off, reaching 0 at the next foot.
double raw_wave(double phase) {
  const double at_foot = waves(0.0), at_crest = waves(kRunOffStart);
  if (phase < kRunOffStart)
    return std::max(0.0, waves(phase) - at_foot * (1.0 - phase / kRunOffStart));
  const double end = std::exp(-(1.0 - kRunOffStart) / kRunOffTau);
  return at_crest * (std::exp(-(phase - kRunOffStart) / kRunOffTau) - end) / (1.0 - end);
}

struct WaveTable {
  std::array<double, kTable + 1> w{};
  WaveTable() {
    double peak = 0.0;
    for (int i = 0; i <= kTable; ++i)
      peak = std::max(peak, raw_wave(static_cast<double>(i) / kTable));
    for (int i = 0; i <= kTable; ++i) w[i] = raw_wave(static_cast<double>(i) / kTable) / peak;
    w[kTable] = w[0];  // the wrap
  }
};

const WaveTable& wave_table() {
  static const WaveTable table;
  return table;
}

}  // namespace

LayerStack::LayerStack(std::vector<StructureLayer> layers) {
  if (layers.size() > kMaxLayers)
    throw UsageError("structure layers: " + std::to_string(layers.size()) + " given, at most " +
                     std::to_string(kMaxLayers));
  if (layers.empty()) return;
  grid_ = layers.front().map.grid;
  const std::size_t n = layers.size();
  const std::size_t voxels = grid_.voxel_count();
  for (const StructureLayer& layer : layers) {
    const Grid& g = layer.map.grid;
    if (g.dims != grid_.dims || g.spacing != grid_.spacing || layer.map.data.size() != voxels)
      throw UsageError("structure layer '" + layer.name + "': its map is not on the others' grid");
  }
  records_.resize(voxels * n);
  for (std::size_t i = 0; i < n; ++i) {
    names_.push_back(layers[i].name);
    kinds_.push_back(layers[i].kind);
    const std::vector<float>& d = layers[i].map.data;
    for (std::size_t v = 0; v < voxels; ++v) {
      if (!std::isfinite(d[v]))
        throw UsageError("structure layer '" + layers[i].name + "': a non-finite distance");
      records_[v * n + i] = d[v];
    }
    std::vector<float>().swap(layers[i].map.data);  // freed once interleaved
  }
  sampling::set_grid(geometry_, grid_);
}

const char* to_string(LayerKind kind) {
  return kind == LayerKind::Artery ? "artery" : "organ";
}

double pulse_waveform(double phase) {
  if (!std::isfinite(phase)) return 0.0;
  phase -= std::floor(phase);
  const double u = phase * kTable;
  const int i = std::min(static_cast<int>(u), kTable - 1);
  const double t = u - i;
  const auto& w = wave_table().w;
  return w[i] + (w[i + 1] - w[i]) * t;
}

double strip_transmission(double depth_mm, double lateral_mm, double width_mm) {
  const double h = std::max(depth_mm, 1e-9);
  const double a = lateral_mm - 0.5 * width_mm, b = lateral_mm + 0.5 * width_mm;
  const double t =
      std::atan(b / h) - std::atan(a / h) + b * h / (b * b + h * h) - a * h / (a * a + h * h);
  return std::clamp(t / std::numbers::pi, 0.0, 1.0);
}

double pulse_force(const ForceParams& p, double depth_mm, double lateral_mm, double press_N,
                   double wave) {
  const double T = strip_transmission(depth_mm, lateral_mm, p.pad_mm);
  const double p_dia = p.pulse_diastolic_mmHg * kMmHgToNPerMm2;
  const double p_sys = p.pulse_systolic_mmHg * kMmHgToNPerMm2;
  const double p_finger = std::max(0.0, press_N) / (p.pad_mm * p.pad_mm) * T;
  const double pressure = p_dia + std::clamp(wave, 0.0, 1.0) * (p_sys - p_dia);
  const double excess = pressure - std::max(p_dia, p_finger);
  return excess > 0.0 ? excess * p.pulse_vessel_mm * p.pad_mm * T : 0.0;
}

double pulse_amplitude(const ForceParams& p, double depth_mm, double lateral_mm, double press_N) {
  return pulse_force(p, depth_mm, lateral_mm, press_N, 1.0);
}

double organ_force(const ForceParams& p, double distance_mm, double* slope) {
  const double c = p.organ_reach_mm - distance_mm;
  double f = 0.0, k = 0.0;
  if (c > 0.0) {
    f = (p.organ_k1 + p.organ_k3 * c * c) * c;
    k = p.organ_k1 + 3.0 * p.organ_k3 * c * c;
    if (!(f < p.organ_fmax)) f = p.organ_fmax, k = 0.0;
  }
  if (slope) *slope = k;
  return f;
}

}  // namespace palp
