// The multiproxy palpation force model (spec "Force model per contact point", paper eqs. 1-13).
//
// Split in the manner of MuJoCo's mjModel / mjData:
//   Model  constant: the sampled distance maps, the parameters and the tool's contact points.
//          Built once at setup; may be shared by any number of States and threads.
//   State  everything that changes from tick to tick, preallocated by make_state(model): per
//          contact point the position, surface point, previous surface point, proxy, contact
//          flag and force, and the device outputs.
//   tick   one haptic step: device pose in, forces out. No allocation, no exceptions, no NaN
//          or infinity in any output.
//
// Choices where the spec leaves room (also in docs):
//   - alpha(z) is evaluated as (1/z_max) / (1 + (z_stick/z)^8) for z > 0 and 0 for z <= 0: the
//     same function, free of 0/0 when z_stick = 0 (no pressing force), where it equals 1/z_max.
//   - |grad D_surf| < grad_epsilon at a point in contact: no skin direction. The point stays in
//     contact (it is inside the body) but gets no surface force (v_s = 0), and its surface point
//     is held where it was (or is x itself on entry), so the proxy neither jumps nor creeps.
//   - |grad D_bone| < grad_epsilon, or |d_bone| < direction_epsilon: no bone force.
//   - A pose with a non-finite (or |coordinate| >= 1e9 mm) component or a zero quaternion: no
//     point is in contact, every output is zero (x = s = p = 0 too) and kTickBadPose is set.
//     A non-unit quaternion is normalised.
//   - A contact point whose force or proxy came out non-finite (not expected with finite maps)
//     is dropped from contact for that tick and kTickNonFinite is set.
//   - Points not in contact report s = p = x, zero force and zero depth.
//
// Bone modes (ForceParams::bone_mode):
//   Printed (default; offline runs follow the spec)  eqs. 4-5 as printed: inside bone
//          (D_bone > 0) the law gives no force, so a user pushing harder than the cap plus the
//          skin law ends up inside a rib, and past a thin rib the force may vanish or flip.
//   Robust  a bone proxy (god-object) per contact point. While a point is outside bone on the
//          skin side (v_b . v_s > 0) its nearest bone surface point e = x + D_bone v_b and the
//          outward normal n = v_b are remembered. When the point enters bone - found inside, or
//          its straight path since the previous tick crosses bone (sampled every half voxel) -
//          the proxy latches on e: the bone force becomes (bone_fmax + bone_k * pen) n with
//          pen = (e - x) . n, continuous with the capped law at the surface and growing without
//          bound, so no finite push tunnels through. The latch lets go when the point is back
//          above the entry plane (pen <= 0), when it is outside bone with no bone between it and
//          that plane along n (it slid off the bone sideways), or when contact is lost. A point
//          that enters bone with no remembered surface (it entered contact inside bone, or
//          approached from beneath) latches with n = v_s and e = x + D_bone v_s.
//
// Two models (ForceParams::model):
//   paper  the spec's equations as printed, bit for bit: the reference the paper's figures and
//          the independent checks use. ForceParams' defaults (and default_params) are this one.
//   palp   the commands' default (palp_params): changes only what measurement justified, each
//          behind its own parameter (docs/force_model.md):
//          - skin law saturating smoothly at skin_fmax, f = f_s / (1 + (f_s / skin_fmax)^4)^(1/4),
//            and past the distance band (no gradient) the point keeps its last skin normal;
//          - bone felt along the skin normal (bone_along_normal): the bone law of the distance
//            to bone along -v_s (sphere-traced on D_bone one step past |D_bone(x)|, a lower
//            bound exact for bone straight beneath), pushing out along v_s, where v_b . v_s > 0,
//            so an intercostal space (bone beside, not beneath) feels soft; faded in with skin
//            depth over bone_fade_mm (smoothstep) so first contact brings no step;
//          - bone as a constraint (the bone proxy of Robust mode, always): a latched point's
//            contact point is held on the bone's entry plane (a god-object), pushed further
//            out along its normal where that plane cuts into a curved, voxelised bone, and never
//            let go while inside bone; State::x reports that point, the skin is sampled there,
//            and the spring bone_fmax + bone_k * pen pushes the device out, so no contact point
//            is ever inside bone;
//          - Coulomb friction: the proxy sticks while |s - p| (tangential) <= mu f_n / k and
//            slides on that circle beyond it, placed from positions alone: |f_friction| <=
//            mu f_n always, no friction without pressing, and the same at every speed and rate.
//          The scene's gradient for palp defaults to the precomputed field (continuous normals).
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <string_view>
#include <vector>

#include "base/vec.hpp"
#include "model/field_sampler.hpp"
#include "model/structure_layers.hpp"
#include "model/tool.hpp"

namespace palp {

enum class BoneMode { Printed, Robust };
enum class ModelKind { Paper, Palp };

struct ForceParams {
  double c = 2.0;                   // mm/N: friction stick length per newton of pressing force
  double k = 0.4;                   // N/mm: proxy spring stiffness
  double bone_fmax = 40.0;          // N: cap of the bone force law
  double bone_flip = 4.0;           // eq. 4 factor in d_bone = v_b - flip * v_s (v_b . v_s)
  bool bone_enabled = true;         // false skips the bone terms
  double grad_epsilon = 1e-6;       // |grad D| below this (mm/mm): no direction
  double direction_epsilon = 1e-9;  // |d_bone| below this: no bone force
  BoneMode bone_mode = BoneMode::Printed;  // Robust: bone proxy, no tunnelling (see above)
  double bone_k = 10.0;                    // N/mm: Robust mode's spring past the bone surface
  ModelKind model = ModelKind::Paper;      // palp: the parameters below apply (see above)
  double mu = 0.5;                // palp: Coulomb friction coefficient (finger-skin 0.3-0.8)
  double skin_fmax = 30.0;        // palp: N, where the skin law saturates
  double bone_fade_mm = 4.0;      // palp: skin depth over which the bone force fades in (0: none)
  bool bone_along_normal = true;  // palp: bone distance along the skin normal
  // palp: the printed bone law's 5 mm (f_b = 20 (x / 5)^-3) made this reach, so ribs 15-20 mm
  // under the skin stand out at working depths (docs/force_model.md, "Rib contrast"). palp's
  // default is palp_params()'s 9 mm; this 8 mm is what a paper model reports (it never reads it).
  double bone_reach_mm = 8.0;
  // Structure layers (structure_layers.hpp; palp model only, and only where the scene has them).
  double pulse_bpm = 72.0;             // heart rate of the arteries' pulse; 0 = no pulse
  double pulse_systolic_mmHg = 120.0;  // the arterial pressure's peak
  double pulse_diastolic_mmHg = 80.0;  // and its floor
  // The width of the artery's wall that bears on the tissue above (a femoral artery is 6-10 mm
  // across) and the square of tissue the fingertip's pad loads; both set so that the defaults
  // give the measured human range (0.02-0.5 N under 2-5 N) over an artery under 10-20 mm of
  // tissue and occlude it at 7-10 N (docs/force_model.md "Structures as layers").
  double pulse_vessel_mm = 5.0;
  double pad_mm = 20.0;
  double organ_reach_mm = 30.0;  // an organ border is felt this far beneath (mm)
  double organ_k1 = 0.03;        // N/mm: the border spring's linear term
  double organ_k3 = 4e-4;        // N/mm^3: and its cubic term
  double organ_fmax = 8.0;       // N: its cap
};

// "paper" | "palp"; UsageError otherwise.
ModelKind parse_model_kind(std::string_view name);
const char* to_string(ModelKind kind);

// "printed" | "robust"; UsageError otherwise.
BoneMode parse_bone_mode(std::string_view name);
const char* to_string(BoneMode mode);

// Parameter sets of the spec: fingertip c = 2.0, k = 0.4 (finger, twofinger); ultrasound probe
// c = 0.4, k = 0.3.
ForceParams default_params(ToolKind kind);
// The palp model's set: default_params with model palp, the bone proxy on, mu 0.5 for a fingertip
// on skin and 0.2 for a probe on gel.
ForceParams palp_params(ToolKind kind);
// The set of `kind` for a tool (palp_params or default_params).
ForceParams model_params(ModelKind kind, ToolKind tool);

// Overrides one parameter by name: c, k, bone_fmax, bone_flip, bone_enabled (0/1),
// grad_epsilon, direction_epsilon, bone_mode (0 = printed, 1 = robust), bone_k, model (0 = paper,
// 1 = palp), mu, skin_fmax, bone_fade_mm, bone_reach_mm,
// bone_along_normal (0/1), pulse_bpm, pulse_systolic_mmHg, pulse_diastolic_mmHg, pulse_vessel_mm,
// pad_mm, organ_reach_mm, organ_k1, organ_k3, organ_fmax.
// UsageError for unknown names or unusable values.
void set_param(ForceParams& params, std::string_view name, double value);

// UsageError outside the physical ranges: c [0, 20] mm/N, k [0, 5] N/mm, bone_fmax [0, 60] N,
// bone_flip [0, 10], bone_k [0, 100] N/mm, epsilons (0, 0.1], mu [0, 2], skin_fmax [1, 200] N,
// bone_fade_mm [0, 30] mm, bone_reach_mm [1, 20] mm, pulse_bpm [0, 240], diastolic [20, 200]
// mmHg < systolic [40, 300] mmHg, pulse_vessel_mm [1, 40], pad_mm [2, 40], organ_reach_mm
// [0, 60], organ_k1 [0, 5] N/mm, organ_k3 [0, 0.1] N/mm^3, organ_fmax [0, 20] N.
void validate(const ForceParams& params);

// f_s(x) = 1.78e-2 x^3 + 3.82e-3 x^2 + 2.28e-4 x for x > 0, else 0 (mm -> N).
constexpr double surface_force(double depth_mm) {
  return depth_mm > 0.0 ? ((1.78e-2 * depth_mm + 3.82e-3) * depth_mm + 2.28e-4) * depth_mm : 0.0;
}

// df_s/dx (N/mm): the skin law's slope at depth x.
constexpr double surface_force_slope(double depth_mm) {
  return depth_mm > 0.0 ? (3 * 1.78e-2 * depth_mm + 2 * 3.82e-3) * depth_mm + 2.28e-4 : 0.0;
}

// f_b(x) = 20 (x / 5)^-3 for x > 0, else 0, capped at fmax (N). x = -D_bone (mm outside bone).
constexpr double bone_force(double distance_mm, double fmax) {
  if (!(distance_mm > 0.0)) return 0.0;
  const double f = 2500.0 / (distance_mm * distance_mm * distance_mm);  // 20 * 5^3 / x^3
  return f < fmax ? f : fmax;  // x^3 underflowing to 0 gives +inf, capped here
}

// The palp model's skin law: f_s saturated smoothly at fmax, f_s / (1 + (f_s / fmax)^4)^(1/4);
// its slope (N/mm) into *slope when given.
inline double saturated_surface_force(double depth_mm, double fmax, double* slope = nullptr) {
  const double f = surface_force(depth_mm);
  const double r = f / fmax, r2 = r * r;
  const double q = 1.0 + r2 * r2;
  const double root = std::sqrt(std::sqrt(q));
  if (slope) *slope = surface_force_slope(depth_mm) / (q * root);
  return f / root;
}
// Its slope (N/mm): f_s'(x) (1 + r^4)^(-5/4), r = f_s / fmax.
inline double saturated_surface_force_slope(double depth_mm, double fmax) {
  const double r = surface_force(depth_mm) / fmax, r2 = r * r;
  const double q = 1.0 + r2 * r2;
  return surface_force_slope(depth_mm) / (q * std::sqrt(std::sqrt(q)));
}

// |df_b/dx| (N/mm) where the bone law is below its cap, else 0.
constexpr double bone_force_slope(double distance_mm, double fmax) {
  if (!(distance_mm > 0.0)) return 0.0;
  const double x2 = distance_mm * distance_mm;
  if (!(2500.0 / (x2 * distance_mm) < fmax)) return 0.0;
  return 7500.0 / (x2 * x2);
}

class Model {
 public:
  // UsageError for unusable parameters or a tool without points.
  Model(std::shared_ptr<const FieldSampler> fields, Tool tool, ForceParams params);
  // Parameters default to the tool kind's set.
  Model(std::shared_ptr<const FieldSampler> fields, Tool tool);
  // With structure layers beyond bone (the palp model applies them; the paper model ignores
  // them). UsageError for a layer without a map.
  Model(std::shared_ptr<const FieldSampler> fields, Tool tool, ForceParams params,
        std::vector<StructureLayer> layers);

  const FieldSampler& fields() const { return *fields_; }
  const std::shared_ptr<const FieldSampler>& fields_ptr() const { return fields_; }
  const Tool& tool() const { return tool_; }
  const ForceParams& params() const { return params_; }
  const std::vector<StructureLayer>& layers() const { return layers_; }
  std::size_t contact_count() const { return tool_.points.size(); }

 private:
  std::shared_ptr<const FieldSampler> fields_;
  Tool tool_;
  ForceParams params_;
  std::vector<StructureLayer> layers_;
};

// Status bits of the last tick (State::status).
enum TickStatus : std::uint32_t {
  kTickOk = 0,
  kTickBadPose = 1u << 0,          // non-finite pose or zero quaternion: nothing in contact
  kTickOutsideGrid = 1u << 1,      // some contact point was outside the sampled grid
  kTickNoSkinDirection = 1u << 2,  // some point in contact had |grad D_surf| < epsilon
  kTickNonFinite = 1u << 3,        // a non-finite value was caught and zeroed (should not happen)
  kTickBadState = 1u << 4,         // the State was not made for this Model: nothing computed
  kTickInsideBone = 1u << 5,       // some point in contact was inside bone (D_bone > 0)
  kTickBoneLatched = 1u << 6,      // Robust mode: some point was held by its bone proxy
};

// State::bone_latch values (Robust mode).
enum BoneLatch : std::uint8_t {
  kBoneFree = 0,     // no bone surface remembered
  kBoneAnchor = 1,   // outside bone on the skin side: bone_anchor / bone_normal are current
  kBoneLatched = 2,  // entered bone: held on bone_anchor, pushed out along bone_normal
};

struct State {
  // Per contact point, index-aligned with Model::tool().points.
  std::vector<Vec3d> x;           // position, scene frame (mm)
  std::vector<Vec3d> s;           // surface point s = x + D_surf v_s
  std::vector<Vec3d> s_prev;      // surface point of the previous tick
  std::vector<Vec3d> p;           // friction proxy
  std::vector<Vec3d> f;           // total force f_surf + f_friction + f_structures (N)
  std::vector<Vec3d> f_friction;  // k (p - s), N
  std::vector<Vec3d> f_bone;      // f_structures (N), zero when none
  std::vector<double> depth;      // D_surf(x) when in contact, else 0 (mm)
  std::vector<std::uint8_t> in_contact;
  // Robust bone mode, per contact point (unused, kBoneFree, in Printed mode).
  std::vector<Vec3d> bone_anchor;        // remembered / latched bone surface point e
  std::vector<Vec3d> bone_normal;        // outward bone normal n at e
  std::vector<std::uint8_t> bone_latch;  // BoneLatch
  std::vector<Vec3d> normal;             // palp: the last skin normal v_s (kept past the band)

  // Device outputs: means over the points in contact (zero when none).
  Vec3d f_device{};    // N
  Vec3d tau_device{};  // N·mm, about the device point
  Vec3d u{};           // mean of p - x over points in contact (mm)
  // Mean over the points in contact of the slopes of their force laws (skin law at its depth,
  // bone law at its distance or the bone proxy's spring, plus the friction spring k), N/mm: a
  // bound on how fast f_device changes per millimetre the tool moves (the curvature of the
  // surfaces aside). The virtual coupling (safety/virtual_coupling.hpp) steps its tool with it.
  double stiffness = 0.0;
  // Structure layers, device means over the points in contact (zero without layers): the
  // arteries' pulse (an active term: the passivity observer counts it as a known input) and the
  // organ borders' springs. Both are part of f_device.
  Vec3d f_pulse{};  // N
  Vec3d f_organ{};  // N
  // The pulse's clock. Input: pulse_bpm (from ForceParams::pulse_bpm at make_state(model); the
  // loop may change it between ticks). Kept: the beat's phase in [0, 1), advanced by the time
  // given to tick() times bpm / 60, and that time. Output: pulse_wave = pulse_waveform(phase).
  double pulse_bpm = 0.0;
  double pulse_phase = 0.0;
  double pulse_wave = 0.0;
  double time_s = 0.0;
  bool clock_started = false;
  int n_contact = 0;
  std::uint32_t status = kTickOk;
  std::uint64_t ticks = 0;
};

// A State sized for the model, every point out of contact.
State make_state(const Model& model);
// A State for `contact_count` points (the tick's stages alone, in tests).
State make_state(std::size_t contact_count);
// Forgets all contacts and outputs (keeps the allocation).
void reset(State& state);

// One haptic tick at the given device pose. `state` must come from make_state(model).
// `time_s`: the tick's time (s, any origin, non-decreasing; a step back or a non-finite time holds
// the pulse's phase): the pulse's clock. Without it the clock stands still (no pulse).
void tick(const Model& model, State& state, const Pose& device_pose, double time_s);
void tick(const Model& model, State& state, const Pose& device_pose);

}  // namespace palp
