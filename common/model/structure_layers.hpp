// Structures beyond bone as layers of the palp model: each layer is a distance map (positive inside
// the structure, mm, scene frame), a force law and, for an artery, a time-varying term.
//
//   artery  a pressurised, compliant tube under the tissue: the finger feels the pressure's rise
//           and fall above its diastolic level, carried to the skin through the tissue as a line
//           load through an elastic half-space (Flamant's solution), and lost while the finger's
//           own pressure at the vessel holds the lumen shut (occlusion).
//   organ   the stiffer response at an organ's border (Mastmeyer et al., Sci Rep 7:671, 2017:
//           a non-linear spring effective at organ borders): with the organ beneath the skin
//           normal within organ_reach_mm, a spring k1 c + k3 c^3 on c = reach - distance.
//
// Veins are not a layer (they do not pulse and are softer than the tissue around them).
//
// The laws here are pure functions (tests drive them alone); the tick's stage that applies them
// per contact point is layer_forces in tick_stages.hpp. docs/force_model.md, "Structures as
// layers", gives the sources and figures.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "base/vec.hpp"
#include "base/volume.hpp"
#include "model/field_sampler.hpp"

namespace palp {

struct ForceParams;

enum class LayerKind { Artery, Organ };
const char* to_string(LayerKind kind);

// One structure: its name ("artery", "liver"), its law, and its distance map (positive inside,
// mm; voxel (i, j, k) at (i, j, k) * spacing in the scene frame, as the scene's maps).
struct StructureLayer {
  std::string name;
  LayerKind kind = LayerKind::Organ;
  DistanceMap map;
};

// The layers of a scene as one constant stack: every map on one grid, interleaved one float per
// layer per voxel, so the tick samples all of them at a point from one cell's 8 records, inline
// (value and the analytic gradient of the trilinear interpolant, as FieldSampler's
// AnalyticTrilinear does for one float map).
class LayerStack {
 public:
  static constexpr std::size_t kMaxLayers = 8;
  // Moves the maps in (each freed once interleaved). UsageError for more than kMaxLayers layers,
  // maps on different grids or holding a non-finite value.
  explicit LayerStack(std::vector<StructureLayer> layers);

  std::size_t size() const { return names_.size(); }
  bool empty() const { return names_.empty(); }
  const std::string& name(std::size_t i) const { return names_[i]; }
  LayerKind kind(std::size_t i) const { return kinds_[i]; }
  const Grid& grid() const { return grid_; }
  std::size_t bytes() const { return records_.size() * sizeof(float); }

  // Every layer at x: out[i] for i < size() (not inside, and no direction, off the grid).
  void sample(const Vec3d& x, FieldSample* out) const {
    const std::size_t n = names_.size();
    for (std::size_t i = 0; i < n; ++i) {
      const sampling::MapView<float> view{records_.data() + i, n, 1.0, nullptr, 3};
      out[i] = sampling::sample<GradientScheme::AnalyticTrilinear>(geometry_, view, x);
    }
  }

 private:
  std::vector<std::string> names_;
  std::vector<LayerKind> kinds_;
  Grid grid_;
  sampling::Geometry geometry_;
  std::vector<float> records_;
};

// 1 mmHg in N/mm^2 (133.322 Pa).
inline constexpr double kMmHgToNPerMm2 = 133.322e-6;

// The normalised arterial pressure waveform w(phase) in [0, 1] over one beat, phase in [0, 1):
// 0 at the foot of the upstroke (end diastole), 1 at the systolic peak, a dicrotic notch between
// the systolic and the dicrotic wave, then the diastolic decay back to 0. A sum of three Gaussian
// waves (percussion, tidal, dicrotic: pulse decomposition analysis) with an exponential diastolic
// run-off, normalised once from a table; the phase wraps (w(phase + 1) = w(phase)).
double pulse_waveform(double phase);

// Flamant's line load through an elastic half-space, integrated over a strip: the share of a line
// load at depth `depth_mm` that bears on a strip of width `width_mm` whose centre lies
// `lateral_mm` to the side (and, by reciprocity, the share of a strip load's pressure that
// reaches the line). (1/pi) [atan(b/h) - atan(a/h) + b h / (b^2 + h^2) - a h / (a^2 + h^2)],
// a = lateral - width/2, b = lateral + width/2; 1 for depth -> 0 under the strip, 0 far away.
double strip_transmission(double depth_mm, double lateral_mm, double width_mm);

// The pulse at a contact point: `depth_mm` / `lateral_mm` of the vessel's centre line from the
// point (along -v_s / across it), `press_N` the point's normal force from the skin (what holds the
// lumen shut), `wave` = pulse_waveform(phase). The force (N, along v_s) the tube's pressure above
// max(diastolic, the finger's pressure at the vessel) puts on the pad:
//   p_finger = press / pad^2 * T,  P(t) = P_dia + wave (P_sys - P_dia),
//   f = max(0, P(t) - max(P_dia, p_finger)) * vessel_mm * pad_mm * T,  T = strip_transmission.
// Zero when the finger's pressure at the vessel reaches systolic (occluded).
double pulse_force(const ForceParams& params, double depth_mm, double lateral_mm, double press_N,
                   double wave);
// Its largest value over a beat at that place and press (wave = 1), for tables and tests.
double pulse_amplitude(const ForceParams& params, double depth_mm, double lateral_mm,
                       double press_N);

// The organ border's spring (N) and its slope (N/mm) at `distance_mm` from the organ (>= 0
// outside, < 0 inside), c = max(0, reach - distance): k1 c + k3 c^3, capped at organ_fmax.
double organ_force(const ForceParams& params, double distance_mm, double* slope = nullptr);

}  // namespace palp
