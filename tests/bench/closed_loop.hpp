// The closed loop shared by the studies of stability (study_passivity, study_stability): one
// degree of freedom along the skin normal, a flat skin (optionally over a bone plate), the force
// model ticked on a device height, a device class (mass, viscous damping, encoder resolution) and
// a hand (a mass coupled to the device by the grip, damped by the arm).
//
// Device class assumptions (no datasheet gives all of these; they set the scale only):
//   touch             device mass 0.045 kg, damping 0.1 N s/m, encoder 0.055 mm
//   falcon            0.15 kg, 0.5 N s/m, 0.06 mm
//   phantom-premium   0.075 kg, 0.2 N s/m, 0.03 mm
//   omega             0.20 kg, 1.0 N s/m, 0.01 mm
//   hand              0.30 kg, grip 0.5 N/mm and 2 N s/m, arm damping 3 N s/m
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "bench/study_util.hpp"
#include "model/field_sampler.hpp"
#include "model/force_model.hpp"
#include "model/tool.hpp"

namespace palp::study {

constexpr double kSimDt = 1e-5;  // s: the plant (device and hand) is integrated at 100 kHz

struct DeviceClass {
  const char* profile;
  double mass_kg, damping_Ns_per_m, encoder_mm;
};
// Both studies run every class.
constexpr DeviceClass kDeviceClasses[] = {
    {"touch", 0.045, 0.1, 0.055},
    {"falcon", 0.15, 0.5, 0.06},
    {"phantom-premium", 0.075, 0.2, 0.03},
    {"omega", 0.20, 1.0, 0.01},
};

struct Hand {
  double mass_kg = 0.30;
  double grip_N_per_mm = 0.5;
  double grip_Ns_per_m = 2.0;
  double arm_Ns_per_m = 3.0;
};

// The 1-DOF environment: the model's normal force at a device height z (the pad's depth
// follows), evaluated with palp::tick on a flat scene, and its static potential for the
// energy balance.
class Environment {
 public:
  Environment(std::shared_ptr<const FieldSampler> fields, double skin_level, double cx, double cy)
      : model_(std::move(fields), parse_tool("finger:1")),
        state_(make_state(model_)),
        skin_level_(skin_level),
        cx_(cx),
        cy_(cy) {
    // Static law F(z), tabulated every 0.005 mm (no state: a single point pressing straight in
    // has no friction); its potential U(z) = integral of F from z up to the skin, by table too.
    z_top_ = device_z_for_depth(-1.0);
    z_bottom_ = device_z_for_depth(30.0);
    const int n = static_cast<int>((z_top_ - z_bottom_) / kTableStep) + 1;
    force_.resize(n);
    State st = make_state(model_);
    for (int i = 0; i < n; ++i) {
      reset(st);
      tick(model_, st, Pose{{cx_, cy_, z_bottom_ + i * kTableStep}, Quat{}});
      force_[i] = st.f_device.z;
    }
  }

  double device_z_for_depth(double depth) const { return skin_level_ - depth - kFingerPadZ; }
  // The model's force at device height z (one tick; state kept, like the real loop).
  double tick_force(double z) {
    tick(model_, state_, Pose{{cx_, cy_, z}, Quat{}});
    return state_.f_device.z;
  }
  // The model's force at (x, cy, z): one tick, state kept (a slide across the scene).
  Vec3d tick_force_at(double x, double z) {
    tick(model_, state_, Pose{{x, cy_, z}, Quat{}});
    return state_.f_device;
  }
  double cx() const { return cx_; }
  // The model's stiffness (State::stiffness, N/mm) at the last tick_force.
  double stiffness() const { return state_.stiffness; }
  void reset_state() { reset(state_); }
  // Static law with a force clamp and its potential (J), by table.
  double potential(double z, double clamp_N) const {
    // The clamp changes the potential only where |F| > clamp: integrate the clamped table.
    if (clamp_N != cached_clamp_) rebuild_clamped(clamp_N);
    return lookup(clamped_potential_, z);
  }
  // The potential (J) of the law as a virtual coupling of stiffness k_c (N/mm) renders it at
  // device height z: the tool rests at z_v where the coupling's spring holds the (clamped) law,
  // z_v - F(z_v) / k_c = z (a tool held at a jump of the law stretches the spring between), and
  // the potential is the law's at z_v plus the spring's, s^2 / (2 k_c), s = k_c (z_v - z).
  double coupled_potential(double z, double k_c, double clamp_N) const {
    if (clamp_N != cached_clamp_) rebuild_clamped(clamp_N);
    const auto g = [&](double zv) { return zv - std::min(lookup(force_, zv), clamp_N) / k_c; };
    double lo = z_bottom_, hi = z_top_;                    // g is increasing in z_v
    if (g(hi) <= z) return lookup(clamped_potential_, z);  // above the law: free
    if (g(lo) >= z) lo = z - 1e3;                          // below the table: spring only
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      (g(mid) < z ? lo : hi) = mid;
    }
    const double zv = hi;
    const double spring = std::min(k_c * (zv - z), clamp_N);
    return lookup(clamped_potential_, zv) + spring * spring / (2.0 * k_c) * 1e-3;
  }
  // Depth where the static law's force equals f (N), and the law's stiffness there (N/mm).
  void equilibrium(double f, double& depth, double& stiffness) const {
    const int n = static_cast<int>(force_.size());
    for (int i = n - 1; i > 0; --i) {
      if (force_[i - 1] >= f && force_[i] < f) {
        const double z = z_bottom_ + (i - 1) * kTableStep;
        depth = skin_level_ - (z + kFingerPadZ);
        stiffness = (force_[i - 1] - force_[i]) / kTableStep;
        // A jump of the law (the bone force switching on with skin contact) has no stiffness.
        if (stiffness > 100.0) stiffness = std::nan("");
        return;
      }
    }
    depth = stiffness = std::nan("");
  }

 private:
  static constexpr double kTableStep = 0.005;

  double lookup(const std::vector<double>& table, double z) const {
    const double u = (z - z_bottom_) / kTableStep;
    if (u <= 0.0) return table.front();
    if (u >= static_cast<double>(table.size() - 1)) return table.back();
    const auto i = static_cast<std::size_t>(u);
    return table[i] + (table[i + 1] - table[i]) * (u - static_cast<double>(i));
  }
  void rebuild_clamped(double clamp_N) const {
    const std::size_t n = force_.size();
    clamped_potential_.assign(n, 0.0);
    for (std::size_t i = n - 1; i-- > 0;) {
      const double a = std::min(force_[i], clamp_N), b = std::min(force_[i + 1], clamp_N);
      clamped_potential_[i] = clamped_potential_[i + 1] + 0.5 * (a + b) * kTableStep * 1e-3;
    }
    cached_clamp_ = clamp_N;
  }

  Model model_;
  State state_;
  double skin_level_, cx_, cy_;
  double z_top_ = 0.0, z_bottom_ = 0.0;
  std::vector<double> force_;
  mutable std::vector<double> clamped_potential_;
  mutable double cached_clamp_ = std::nan("");
};

// The scene of both studies: a flat skin and, for the bone scene, a bone plate 10 mm under it (a
// wide, flat "rib"); the finger presses at (cx, cy).
struct PressScene {
  RibMaps maps;
  double cx = 20.0, cy = 20.0;
};
inline PressScene make_press_scene() {
  RibScene scene;
  scene.h = 1.0;
  scene.size_x = 40.0;
  scene.size_y = 40.0;
  scene.size_z = 80.0;
  scene.skin_z = 60.0;
  scene.rib_x = 20.0;
  scene.width = 60.0;
  scene.height = 10.0;
  scene.depth = 10.0;
  scene.round = false;
  return PressScene{make_rib_maps(scene), 20.0, 20.0};
}

}  // namespace palp::study
