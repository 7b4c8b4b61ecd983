// The stages of one force-model tick (force_model.hpp), each a small function over one contact
// point's PointWork. force_model.cpp composes them twice: the paper model (the spec's equations
// as printed) and the palp model (docs/force_model.md). A tick is:
//
//   begin_tick        device pose -> usable?, rotation, device point, status
//   per contact point i:
//     place_point     tool-frame point -> scene point x
//     sample_*        x -> D_surf (and D_bone) with gradients
//     skin_contact    D_surf(x) > 0, else the point leaves contact
//     skin_direction  grad D_surf -> v_s (palp: the last normal past the band)
//     bone_*          D_bone, v_b, v_s -> f_structures (the printed law, the bone proxy, or the
//                     palp model's bone along the skin normal)
//     skin_force_*    D_surf at the contact point -> f_surf
//     layer_forces    palp, per structure layer: D_layer, v_s, f_n -> organ border spring (into
//                     f_structures), artery pulse (f_pulse)
//     surface_point   contact point, D_surf, v_s -> s, and the last s and p
//     friction_*      s, last p, f_n -> proxy p and f_friction (eqs. 7-10, or Coulomb)
//     commit_point    -> State[i] and the device sums (a non-finite point is dropped)
//   device_outputs    sums -> f_device, tau_device, u, stiffness (eqs. 12-13)
//
// Every stage is inline and allocation-free; `Access` is a FieldAccess (field_sampler.hpp), so
// the chain is monomorphic per scheme and storage. The stages are in palp::tick_stages so tests
// can drive each one alone (tests/common/model/tick_stages_test.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "model/force_model.hpp"

namespace palp::tick_stages {

// Every stage is inlined into the tick: the chain must cost what one hand-written function did
// (palp bench, docs/force_model.md "The tick's stages"); GCC otherwise calls the larger ones.
#define PALP_STAGE [[gnu::always_inline]] inline

// Positions beyond this (mm) are not a pose a device can report; they count as a bad pose.
constexpr double kMaxPoseCoordinate = 1.0e9;
// Bone on a segment is looked for at most this many samples (a longer one is sampled coarser).
constexpr int kMaxBoneSamples = 64;
// The bone proxy's push-out of a held point its entry plane left inside bone: at most this many
// steps, ending this far (mm) outside the bone.
constexpr int kHoldSteps = 8;
constexpr double kHoldMargin = 0.01;

// One tick's constants and accumulators (on the tick's stack).
struct TickRun {
  const ForceParams* prm = nullptr;
  bool pose_ok = false;
  Quat q{};                // the device's orientation, normalised (identity when !pose_ok)
  Vec3d xd{};              // the device point (scene mm)
  bool bone_on = false;    // a bone map and bone terms enabled
  double bone_step = 0.0;  // mm between samples when looking for bone on a segment
  std::uint32_t status = kTickOk;
  // The structure layers (palp model; none for the paper model) and the pulse's wave this tick.
  const LayerStack* layers = nullptr;
  std::size_t n_layers = 0;
  double pulse_wave = 0.0;
  // The layers sampled once at the pad's centre (layers_at_pad), carried to each point to first
  // order.
  Vec3d pad_centre{};
  FieldSample at_pad[LayerStack::kMaxLayers];
  Vec3d pulse_sum{}, organ_sum{};
  // Sums over the points in contact, for the device means (eqs. 12-13).
  Vec3d f_sum{}, tau_sum{}, u_sum{};
  double k_sum = 0.0;
  int n_contact = 0;
};

// One contact point through one tick (on the stack; nothing allocated).
struct PointWork {
  Vec3d x{};              // the tool's point in the scene
  Vec3d xc{};             // the contact point: x, or held by the bone proxy on its entry plane
  bool entering = false;  // was out of contact last tick
  FieldSample skin;       // D_surf at the contact point
  FieldSample bone;       // D_bone at x
  Vec3d v_s{};            // skin normal, out of the body (zero without a direction)
  bool has_dir = false;
  Vec3d v_b{};  // bone normal, out of the bone (zero without a direction)
  bool has_vb = false;
  bool inside_bone = false;  // D_bone(x) > 0
  bool latched = false;      // the bone proxy holds the point
  double depth = 0.0;        // D_surf at the contact point, >= 0
  Vec3d f_surf{}, f_struct{}, f_friction{};
  Vec3d f_pulse{}, f_organ{};  // the layers' terms (f_organ is also in f_struct)
  Vec3d s{}, s_last{}, p_last{}, p{};
  double k_skin = 0.0, k_struct = 0.0, k_friction = 0.0;  // slopes of the laws (N/mm)
};

// How the bone proxy (god-object) behaves: the paper model's Robust bone mode, or the palp
// model's bone as a constraint (force_model.hpp, "Bone modes" and "Two models").
struct BoneProxyRule {
  // Entering bone with no remembered surface: latch along v_b (else along v_s, v_b without one).
  bool entry_along_bone_normal = false;
  // Hold the contact point on the entry plane (pushed out where that plane cuts into the bone),
  // and never let go while x is inside bone.
  bool constrain_contact = false;
};
constexpr BoneProxyRule kPaperBoneProxy{false, false};
constexpr BoneProxyRule kPalpBoneProxy{true, true};

// 3t^2 - 2t^3 on [0, 1], 0 below and 1 above: a C1 fade.
PALP_STAGE double smoothstep(double t) {
  if (!(t > 0.0)) return 0.0;
  if (t >= 1.0) return 1.0;
  return t * t * (3.0 - 2.0 * t);
}

// palp: the fade-in of a structure beneath with skin depth, smoothstep(depth / bone_fade_mm)
// (1 when bone_fade_mm is 0): no step at first touch.
PALP_STAGE double depth_fade(const ForceParams& prm, double depth_mm) {
  return prm.bone_fade_mm > 0.0 ? smoothstep(depth_mm / prm.bone_fade_mm) : 1.0;
}

PALP_STAGE bool pose_usable(const Pose& pose) {
  const Vec3d& x = pose.position;
  if (!(std::fabs(x.x) < kMaxPoseCoordinate && std::fabs(x.y) < kMaxPoseCoordinate &&
        std::fabs(x.z) < kMaxPoseCoordinate))
    return false;  // also catches NaN
  const double qn = norm(pose.orientation);
  return std::isfinite(qn) && qn > 1e-12;
}

// device pose -> usable?, rotation, device point, status (kTickBadPose for an unusable pose).
PALP_STAGE TickRun begin_tick(const ForceParams& prm, bool has_bone, double bone_step,
                              const Pose& pose) {
  TickRun run;
  run.prm = &prm;
  run.pose_ok = pose_usable(pose);
  run.q = run.pose_ok ? normalized(pose.orientation) : Quat{};
  run.xd = run.pose_ok ? pose.position : Vec3d{};
  run.bone_on = has_bone && prm.bone_enabled;
  run.bone_step = bone_step;
  run.status = run.pose_ok ? kTickOk : kTickBadPose;
  return run;
}

// tool-frame point -> scene point: x = x_device + R(q) x_tool (the origin for an unusable pose).
PALP_STAGE Vec3d place_point(const TickRun& run, const Vec3d& tool_point) {
  return run.pose_ok ? run.xd + rotate(run.q, tool_point) : Vec3d{};
}

// A point's work starts at x with no bone term (the tick reuses one PointWork for all points:
// every other field is written by the stage that produces it before any stage reads it).
PALP_STAGE void begin_point(const Vec3d& x, PointWork& w) {
  w.x = w.xc = x;
  w.latched = false;
  w.f_struct = Vec3d{};
  w.k_struct = 0.0;
  w.f_pulse = w.f_organ = Vec3d{};
}

// Point i leaves (or is out of) contact: no force, proxies and normal forgotten, s = p = x.
PALP_STAGE void drop_point(State& st, std::size_t i, const Vec3d& x) {
  st.in_contact[i] = 0;
  st.x[i] = x;
  st.s[i] = x;
  st.s_prev[i] = x;
  st.p[i] = x;
  st.f[i] = Vec3d{};
  st.f_friction[i] = Vec3d{};
  st.f_bone[i] = Vec3d{};
  st.depth[i] = 0.0;
  st.bone_latch[i] = kBoneFree;
  st.normal[i] = Vec3d{};
}

// x -> D_surf at x (kTickOutsideGrid when x is off the grid).
template <class Access>
PALP_STAGE void sample_skin(const Access& fields, TickRun& run, PointWork& w) {
  w.skin = fields.surf_at(w.x);
  if (!w.skin.inside) run.status |= kTickOutsideGrid;
}

// x -> D_surf and D_bone at x in one pass where the maps are interleaved.
template <class Access>
PALP_STAGE void sample_skin_and_bone(const Access& fields, TickRun& run, PointWork& w) {
  if (run.bone_on) {
    fields.surf_and_bone_at(w.x, w.skin, w.bone);
  } else {
    w.skin = fields.surf_at(w.x);
  }
  if (!w.skin.inside) run.status |= kTickOutsideGrid;
}

// D_bone's gradient -> v_b; D_bone(x) > 0 -> inside. The sample is already in w.bone.
PALP_STAGE void bone_direction(const ForceParams& prm, PointWork& w) {
  const double g = norm(w.bone.grad);
  w.has_vb = g >= prm.grad_epsilon;
  w.v_b = w.has_vb ? w.bone.grad * (-1.0 / g) : Vec3d{};
  w.inside_bone = w.bone.value > 0.0;
}

// x -> D_bone at x and its direction.
template <class Access>
PALP_STAGE void sample_bone(const Access& fields, const ForceParams& prm, PointWork& w) {
  w.bone = fields.bone_at(w.x);
  bone_direction(prm, w);
}

// (2) In contact iff D_surf(x) > 0; otherwise the point is dropped. Sets entering.
PALP_STAGE bool skin_contact(State& st, std::size_t i, PointWork& w) {
  if (!(w.skin.value > 0.0)) {
    drop_point(st, i, w.x);
    return false;
  }
  w.entering = st.in_contact[i] == 0;
  return true;
}

// (1) v_s = -grad D_surf / |grad D_surf|; without a gradient zero, or with `keep_last_normal`
// the point's last normal (not on entry). Sets kTickNoSkinDirection only through
// flag_skin_direction, after the composition has settled v_s.
PALP_STAGE void skin_direction(const ForceParams& prm, const State& st, std::size_t i,
                               bool keep_last_normal, PointWork& w) {
  const double g = norm(w.skin.grad);
  w.has_dir = g >= prm.grad_epsilon;
  if (w.has_dir) {
    w.v_s = w.skin.grad * (-1.0 / g);
  } else if (keep_last_normal && !w.entering && !(st.normal[i] == Vec3d{})) {
    w.has_dir = true;
    w.v_s = st.normal[i];
  } else {
    w.v_s = Vec3d{};
  }
}

PALP_STAGE void flag_skin_direction(TickRun& run, const PointWork& w) {
  if (!w.has_dir) run.status |= kTickNoSkinDirection;
}

// Whether bone lies on the straight segment a -> b, sampled every `step` mm (at most
// kMaxBoneSamples samples). The end points are not sampled (the caller has them).
template <class Access>
bool segment_hits_bone(const Access& fields, Vec3d a, Vec3d b, double step) {
  const double len = norm(b - a);
  if (!(len > step)) return false;
  const int n = static_cast<int>(std::min(std::ceil(len / step), double{kMaxBoneSamples}));
  for (int k = 1; k < n; ++k) {
    const double t = static_cast<double>(k) / n;
    if (fields.bone_at(a + t * (b - a)).value > 0.0) return true;
  }
  return false;
}

// (4, 5) as printed: f_struct = f_b(-D_bone) d_bone / |d_bone|, d_bone never pointing into the
// skin; zero inside bone or without a direction.
PALP_STAGE void bone_law_printed(const ForceParams& prm, PointWork& w) {
  const double fb = bone_force(-w.bone.value, prm.bone_fmax);
  if (!(fb > 0.0) || !w.has_vb) {
    w.f_struct = Vec3d{};
    return;
  }
  const double vbvs = dot(w.v_b, w.v_s);
  const Vec3d d_bone = vbvs > 0.0 ? w.v_b : w.v_b - (prm.bone_flip * vbvs) * w.v_s;
  const double d_norm = norm(d_bone);
  w.f_struct = d_norm >= prm.direction_epsilon ? (fb / d_norm) * d_bone : Vec3d{};
}

// The bone proxy, step 1: latch when x is in bone or its path since last tick crossed bone;
// latch -> the point's BoneLatch, with its anchor e and normal n set on a fresh latch.
template <class Access>
PALP_STAGE std::uint8_t bone_proxy_enter(const Access& fields, const TickRun& run,
                                         BoneProxyRule rule, State& st, std::size_t i,
                                         const PointWork& w) {
  std::uint8_t latch = w.entering ? std::uint8_t{kBoneFree} : st.bone_latch[i];
  if (latch == kBoneLatched) return latch;
  const bool crossed = w.inside_bone || (latch == kBoneAnchor &&
                                         segment_hits_bone(fields, st.x[i], w.x, run.bone_step));
  if (crossed && latch == kBoneAnchor) return kBoneLatched;
  if (crossed && (w.has_dir || w.has_vb)) {
    // No remembered surface: the nearest bone surface point, or out of the skin.
    const bool along_bone = rule.entry_along_bone_normal ? w.has_vb : !w.has_dir;
    st.bone_normal[i] = along_bone ? w.v_b : w.v_s;
    st.bone_anchor[i] = w.x + w.bone.value * st.bone_normal[i];
    return kBoneLatched;
  }
  return latch;
}

// The bone proxy, step 2: a latched point is held at pen = (e - x) . n behind its entry plane
// with the spring f_struct = (bone_fmax + bone_k pen) n, or let go above the plane (the palp rule:
// never while inside bone) or when it slid off sideways. latch -> latch, w.latched, f_struct.
template <class Access>
PALP_STAGE std::uint8_t bone_proxy_hold(const Access& fields, TickRun& run, BoneProxyRule rule,
                                        const State& st, std::size_t i, std::uint8_t latch,
                                        PointWork& w) {
  if (latch != kBoneLatched) return latch;
  const ForceParams& prm = *run.prm;
  const Vec3d& anchor = st.bone_anchor[i];
  const Vec3d& normal = st.bone_normal[i];
  double pen = dot(anchor - w.x, normal);
  const bool above_plane = !(pen > 0.0);
  const bool slid_off = !w.inside_bone && !above_plane &&
                        !segment_hits_bone(fields, w.x, w.x + pen * normal, run.bone_step);
  const bool release = rule.constrain_contact ? (!w.inside_bone && above_plane) || slid_off
                                              : above_plane || slid_off;
  if (release) return kBoneFree;
  if (rule.constrain_contact) {
    // The plane goes through the distance field's estimate of the entry point; on a curved,
    // voxelised bone it may cut into it: out along n while inside, by twice D_bone and
    // kHoldMargin (steps of D_bone alone only approach the surface).
    if (above_plane) pen = 0.0;
    w.xc = w.x + pen * normal;
    for (int k = 0; k < kHoldSteps; ++k) {
      const double d_in = fields.bone_value_at(w.xc);
      if (!(d_in > 0.0)) break;
      const double out = 2.0 * d_in + kHoldMargin;
      pen += out;
      w.xc += out * normal;
    }
  }
  w.f_struct = (prm.bone_fmax + prm.bone_k * pen) * normal;
  w.k_struct = prm.bone_k;
  w.latched = true;
  run.status |= kTickBoneLatched;
  return latch;
}

// The bone proxy, steps 1 and 2 (enter, hold): whether it holds the point (xc, f_struct set).
template <class Access>
PALP_STAGE bool bone_proxy(const Access& fields, TickRun& run, BoneProxyRule rule, State& st,
                           std::size_t i, PointWork& w) {
  std::uint8_t latch = bone_proxy_enter(fields, run, rule, st, i, w);
  latch = bone_proxy_hold(fields, run, rule, st, i, latch, w);
  if (w.latched) st.bone_latch[i] = latch;
  return w.latched;
}

// The bone proxy, step 3 (a point not held): remember the nearest bone surface point e and its
// normal while x is outside bone on the skin side of it (v_b . v_s > 0). -> the point's latch.
PALP_STAGE void bone_proxy_remember(State& st, std::size_t i, const PointWork& w) {
  if (!w.inside_bone && w.has_vb && dot(w.v_b, w.v_s) > 0.0) {
    st.bone_anchor[i] = w.x + w.bone.value * w.v_b;
    st.bone_normal[i] = w.v_b;
    st.bone_latch[i] = kBoneAnchor;
  } else {
    st.bone_latch[i] = kBoneFree;
  }
}

// palp: bone felt along the skin normal, where v_b . v_s > 0 and x is outside bone: the printed
// law of the distance to bone along -v_s (the bone-beneath map; at least |D_bone|), its 5 mm
// scaled to bone_reach_mm, faded in with skin depth. D_bone, v_s -> f_struct, k_struct.
template <class Access>
PALP_STAGE void bone_along_normal(const Access& fields, const ForceParams& prm, PointWork& w) {
  const double dist = -w.bone.value;
  const double cos_b = w.has_vb && w.has_dir ? dot(w.v_b, w.v_s) : 0.0;
  if (w.inside_bone || !(dist > 0.0) || !(cos_b > 0.0)) return;
  double reach = dist;
  if (prm.bone_along_normal && fields.beneath.value != nullptr)
    reach = std::max(dist, fields.beneath_at(w.x));
  const double fade = depth_fade(prm, w.skin.value);
  const double scale = 5.0 / prm.bone_reach_mm;
  w.f_struct = (bone_force(reach * scale, prm.bone_fmax) * fade) * w.v_s;
  w.k_struct = bone_force_slope(reach * scale, prm.bone_fmax) * scale * fade;
}

// palp: a point the proxy holds off x is sampled where it is held: xc -> D_surf, v_s.
template <class Access>
PALP_STAGE void resample_skin_at_contact(const Access& fields, const ForceParams& prm,
                                         const State& st, std::size_t i, PointWork& w) {
  if (!w.latched) return;
  w.skin = fields.surf_at(w.xc);
  skin_direction(prm, st, i, true, w);
}

// (3) as printed: f_surf = f_s(D_surf) v_s.
PALP_STAGE void skin_force_printed(PointWork& w) {
  w.depth = w.skin.value;
  w.f_surf = surface_force(w.depth) * w.v_s;
  w.k_skin = surface_force_slope(w.depth);
}

// palp: the skin law saturated smoothly at skin_fmax; the normal is kept for past the band.
PALP_STAGE void skin_force_saturated(const ForceParams& prm, State& st, std::size_t i,
                                     PointWork& w) {
  w.depth = std::max(0.0, w.skin.value);
  w.f_surf = saturated_surface_force(w.depth, prm.skin_fmax, &w.k_skin) * w.v_s;
  if (w.has_dir) st.normal[i] = w.v_s;
}

// palp, one artery layer: the vessel's centre line from the contact point (its nearest surface
// point along grad D_layer, then half the vessel's width on), split into depth along -v_s and
// lateral offset; the pulse there under the point's normal force -> f_pulse (along v_s).
PALP_STAGE void artery_layer(const ForceParams& prm, const FieldSample& a, double wave,
                             PointWork& w) {
  const double g = norm(a.grad);
  if (!(g >= prm.grad_epsilon) || !(wave > 0.0)) return;
  const Vec3d toward = a.grad * (1.0 / g);  // into the vessel
  const Vec3d centre = (0.5 * prm.pulse_vessel_mm - a.value) * toward;
  const double depth = std::max(0.0, -dot(centre, w.v_s));
  const double lateral = norm(centre + depth * w.v_s);
  const double press = std::max(0.0, dot(w.f_surf + w.f_struct, w.v_s));
  w.f_pulse += pulse_force(prm, depth, lateral, press, wave) * w.v_s;
}

// palp, one organ layer: the border's spring of the distance to the organ, where the organ lies
// beneath (its outward normal along v_s, weighted by that cosine), faded in with skin depth like
// the bone -> f_organ, added to f_struct and k_struct.
PALP_STAGE void organ_layer(const ForceParams& prm, const FieldSample& o, PointWork& w) {
  const double g = norm(o.grad);
  if (!(g >= prm.grad_epsilon)) return;
  const double cos_o = -dot(o.grad, w.v_s) / g;  // the organ's outward normal . v_s
  if (!(cos_o > 0.0)) return;
  const double fade = depth_fade(prm, w.depth);
  double slope = 0.0;
  const double f = organ_force(prm, -o.value, &slope) * cos_o * fade;
  if (!(f > 0.0)) return;
  w.f_organ += f * w.v_s;
  w.f_struct += f * w.v_s;
  w.k_struct += slope * cos_o * fade;
}

// palp: every structure layer at the contact point (a point without a skin direction, or a map
// that does not reach it, gets nothing from it). xc, v_s, f_n -> f_pulse, f_organ.
PALP_STAGE void layer_forces(const TickRun& run, PointWork& w) {
  if (!w.has_dir || run.n_layers == 0) return;
  for (std::size_t l = 0; l < run.n_layers; ++l) {
    const FieldSample& c = run.at_pad[l];
    if (!c.inside) continue;
    // D(x_c) ~ D(pad) + grad D(pad) . (x_c - pad): one sample a tick for the whole pad.
    FieldSample s = c;
    s.value += dot(c.grad, w.xc - run.pad_centre);
    if (run.layers->kind(l) == LayerKind::Artery) {
      artery_layer(*run.prm, s, run.pulse_wave, w);
    } else {
      organ_layer(*run.prm, s, w);
    }
  }
}

// palp, once a tick: every layer at the centre of the tool's points (placed), from one cell's
// records. pose, tool -> pad_centre, at_pad.
PALP_STAGE void layers_at_pad(TickRun& run, const Vec3d& tool_centre) {
  if (run.n_layers == 0 || !run.pose_ok) return;
  run.pad_centre = place_point(run, tool_centre);
  run.layers->sample(run.pad_centre, run.at_pad);
}

// (6) s = xc + D_surf v_s (held at its last value without a direction); on entry p = s_last = s.
PALP_STAGE void surface_point(const State& st, std::size_t i, PointWork& w) {
  w.s = w.has_dir ? w.xc + w.depth * w.v_s : (w.entering ? w.xc : st.s[i]);
  w.s_last = w.entering ? w.s : st.s[i];
  w.p_last = w.entering ? w.s : st.p[i];
}

// (7-10) as printed: breakaway z_max = c max(0, f_n . v_s) + 1, z_stick = z_max - 1,
// alpha(|d|) = 1 / (z_max (1 + (z_stick / |d|)^8)); the proxy slips to z_max behind s past
// breakaway, else creeps along d = s - p by |s - s_last| alpha. -> p, f_friction = k (p - s).
PALP_STAGE void friction_paper(const ForceParams& prm, PointWork& w) {
  const Vec3d d = w.s - w.p_last;
  const double fn_vs = dot(w.f_surf + w.f_struct, w.v_s);
  const double z_max = prm.c * std::max(0.0, fn_vs) + 1.0;
  const double z_stick = z_max - 1.0;
  const double dist = norm(d);
  double alpha = 0.0;
  if (dist > 0.0) {
    const double r = z_stick / dist;
    const double r2 = r * r;
    const double r4 = r2 * r2;
    alpha = 1.0 / (z_max * (1.0 + r4 * r4));
  }
  w.p =
      alpha * dist > 1.0 ? w.s - (z_max / dist) * d : w.p_last + (norm(w.s - w.s_last) * alpha) * d;
  w.f_friction = prm.k * (w.p - w.s);
  w.k_friction = prm.k;
}

// palp: Coulomb friction placed from positions: the proxy sticks on the tangent plane at s while
// within mu f_n / k of it and slides on that circle beyond. -> p, f_friction.
PALP_STAGE void friction_coulomb(const ForceParams& prm, PointWork& w) {
  const double f_n = std::max(0.0, dot(w.f_surf + w.f_struct, w.v_s));
  const double radius = prm.k > 0.0 ? prm.mu * f_n / prm.k : 0.0;
  Vec3d d = w.s - w.p_last;
  d = d - dot(d, w.v_s) * w.v_s;  // tangential
  const double dn = norm(d);
  w.p = dn <= radius ? w.s - d : w.s - (radius / dn) * d;
  w.f_friction = prm.k * (w.p - w.s);
  w.k_friction = dn <= radius ? prm.k : 0.0;
}

// f = f_surf + f_friction + f_struct -> State[i]; (11) tau = (xc - x_device) x f and the sums of
// (12, 13). A non-finite point is dropped instead (kTickNonFinite); returns whether committed.
PALP_STAGE bool commit_point(TickRun& run, State& st, std::size_t i, const PointWork& w) {
  const Vec3d f = run.n_layers > 0 ? w.f_surf + w.f_friction + w.f_struct + w.f_pulse
                                   : w.f_surf + w.f_friction + w.f_struct;
  if (!is_finite(f) || !is_finite(w.p) || !is_finite(w.s) || !is_finite(w.xc)) {
    run.status |= kTickNonFinite;
    drop_point(st, i, w.x);
    return false;
  }
  st.in_contact[i] = 1;
  st.x[i] = w.xc;
  st.s_prev[i] = w.s_last;
  st.s[i] = w.s;
  st.p[i] = w.p;
  st.f[i] = f;
  st.f_friction[i] = w.f_friction;
  st.f_bone[i] = w.f_struct;
  st.depth[i] = w.depth;
  run.f_sum += f;
  run.tau_sum += cross(w.xc - run.xd, f);
  run.u_sum += w.p - w.xc;
  run.k_sum += w.k_skin + w.k_struct + w.k_friction;
  run.pulse_sum += w.f_pulse;
  run.organ_sum += w.f_organ;
  ++run.n_contact;
  return true;
}

// (12, 13) sums -> device force, torque, displacement u and stiffness: means over the points in
// contact (all zero, kTickNonFinite, should one come out non-finite); status and tick count.
PALP_STAGE void device_outputs(TickRun& run, State& st) {
  const double inv = run.n_contact > 0 ? 1.0 / run.n_contact : 0.0;
  st.f_device = run.f_sum * inv;
  st.tau_device = run.tau_sum * inv;
  st.u = run.u_sum * inv;
  st.stiffness = std::isfinite(run.k_sum) ? run.k_sum * inv : 0.0;
  st.f_pulse = run.pulse_sum * inv;
  st.f_organ = run.organ_sum * inv;
  if (!is_finite(st.f_device) || !is_finite(st.tau_device) || !is_finite(st.u)) {
    run.status |= kTickNonFinite;
    st.f_device = st.tau_device = st.u = st.f_pulse = st.f_organ = Vec3d{};
  }
  st.n_contact = run.n_contact;
  st.status = run.status;
  ++st.ticks;
}

#undef PALP_STAGE

}  // namespace palp::tick_stages
