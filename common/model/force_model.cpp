#include "model/force_model.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "base/errors.hpp"

namespace palp {
namespace {

// Positions beyond this (mm) are not a pose a device can report; they count as a bad pose.
constexpr double kMaxPoseCoordinate = 1.0e9;

bool pose_usable(const Pose& pose) {
  const Vec3d& x = pose.position;
  const Quat& q = pose.orientation;
  if (!(std::fabs(x.x) < kMaxPoseCoordinate && std::fabs(x.y) < kMaxPoseCoordinate &&
        std::fabs(x.z) < kMaxPoseCoordinate))
    return false;  // also catches NaN
  const double qn = norm(q);
  return std::isfinite(qn) && qn > 1e-12;
}

// 3t^2 - 2t^3 on [0, 1], 0 below and 1 above: a C1 fade.
inline double smoothstep(double t) {
  if (!(t > 0.0)) return 0.0;
  if (t >= 1.0) return 1.0;
  return t * t * (3.0 - 2.0 * t);
}

// Point i leaves (or is out of) contact: no force, proxy forgotten, s = p = x.
inline void clear_contact(State& st, std::size_t i, const Vec3d& x) {
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
}

// Robust mode: whether bone lies on the straight segment a -> b, sampled every `step` mm (at most
// kMaxBoneSamples samples; a longer segment is sampled more coarsely). The end points are not
// sampled (the caller has them).
constexpr int kMaxBoneSamples = 64;

template <class Access>
bool segment_hits_bone(const Access& fields, const Vec3d& a, const Vec3d& b, double step) {
  const double len = norm(b - a);
  if (!(len > step)) return false;
  const int n = static_cast<int>(std::min(std::ceil(len / step), double{kMaxBoneSamples}));
  for (int k = 1; k < n; ++k) {
    const double t = static_cast<double>(k) / n;
    if (fields.bone_at(a + t * (b - a)).value > 0.0) return true;
  }
  return false;
}

// Eqs. 4-5 as printed: f_b(-D_bone) d_bone / |d_bone| (zero inside bone or without direction).
inline Vec3d printed_bone_force(const ForceParams& prm, const FieldSample& bone, const Vec3d& v_b,
                                bool has_vb, const Vec3d& v_s) {
  const double fb = bone_force(-bone.value, prm.bone_fmax);
  if (!(fb > 0.0) || !has_vb) return Vec3d{};
  const double vbvs = dot(v_b, v_s);
  const Vec3d d_bone = vbvs > 0.0 ? v_b : v_b - (prm.bone_flip * vbvs) * v_s;
  const double d_norm = norm(d_bone);
  return d_norm >= prm.direction_epsilon ? (fb / d_norm) * d_bone : Vec3d{};
}

// palp's bone along the skin normal: the distance to bone along -v_s is read from the sampler's
// bone-beneath map (model/bone_beneath.hpp, traced to convergence once; Model prepares it), not
// dist / cos(v_b, v_s), the distance to the nearest bone's tangent plane: midway between two ribs
// the distance field's gradient is the bisector of both and points straight along the skin
// normal, so that plane lay beneath and an intercostal space felt like a rib. A few
// sphere-tracing steps in the tick (the previous version: one after |D_bone(x)|) still stopped
// far short of the true distance on the CT, where the nearest bone over a space is a rib beside.

// palp's bone proxy: steps pushing a held point that its entry plane left inside bone out along
// the plane's normal.
constexpr int kHoldSteps = 8;
constexpr double kHoldMargin = 0.01;  // mm

// Accumulators of one tick's device outputs.
struct TickSums {
  Vec3d f{}, tau{}, u{};
  double k = 0.0;
  int n = 0;
};

// The palp model at one contact point x (see force_model.hpp): the bone proxy always, the bone
// felt along the skin normal and faded in with depth, the saturated skin law, the last normal
// past the band, and Coulomb friction placed from positions.
template <class Access>
void palp_point(const Access& fields, const ForceParams& prm, State& st, std::size_t i,
                const Vec3d& x, const Vec3d& xd, bool bone_on, double bone_step,
                std::uint32_t& status, TickSums& sums) {
  // D_surf (and D_bone) at x: one pass over the cell where the maps are interleaved
  FieldSample skin_x, bone_x;
  if (bone_on) {
    fields.surf_and_bone_at(x, skin_x, bone_x);
  } else {
    skin_x = fields.surf_at(x);
  }
  if (!skin_x.inside) status |= kTickOutsideGrid;
  if (!(skin_x.value > 0.0)) {
    clear_contact(st, i, x);
    st.normal[i] = Vec3d{};
    return;
  }
  const bool entering = st.in_contact[i] == 0;
  // v_s at x: from the gradient, or past the band (no gradient) the last normal
  const auto skin_normal = [&](const FieldSample& sample, bool& has_dir) {
    const double g = norm(sample.grad);
    has_dir = g >= prm.grad_epsilon;
    if (has_dir) return Vec3d(sample.grad * (-1.0 / g));
    if (!entering && !(st.normal[i] == Vec3d{})) {
      has_dir = true;
      return st.normal[i];
    }
    return Vec3d{};
  };
  bool has_dir = false;
  Vec3d v_s = skin_normal(skin_x, has_dir);

  // Bone: the proxy (god-object). xc is the contact point: x, or held on the entry plane.
  Vec3d xc = x;
  Vec3d f_struct{};
  double k_struct = 0.0;
  bool latched = false, inside_x = false;
  if (bone_on) {
    const FieldSample& bone = bone_x;
    const double bone_grad_norm = norm(bone.grad);
    const bool has_vb = bone_grad_norm >= prm.grad_epsilon;
    const Vec3d v_b = has_vb ? bone.grad * (-1.0 / bone_grad_norm) : Vec3d{};
    const bool inside_bone = bone.value > 0.0;
    inside_x = inside_bone;
    std::uint8_t latch = entering ? std::uint8_t{kBoneFree} : st.bone_latch[i];
    Vec3d& anchor = st.bone_anchor[i];
    Vec3d& normal = st.bone_normal[i];
    if (latch != kBoneLatched) {
      const bool crossed =
          inside_bone || (latch == kBoneAnchor && segment_hits_bone(fields, st.x[i], x, bone_step));
      if (crossed && latch == kBoneAnchor) {
        latch = kBoneLatched;
      } else if (crossed && (has_vb || has_dir)) {
        // No remembered surface: the nearest bone surface point (or out of the skin).
        normal = has_vb ? v_b : v_s;
        anchor = x + bone.value * normal;
        latch = kBoneLatched;
      }
    }
    if (latch == kBoneLatched) {
      double pen = dot(anchor - x, normal);
      // Let go above the entry plane or slid off sideways, but never while inside bone: the
      // plane is an estimate, and a voxelised bone's staircase may reach above it.
      if (!inside_bone &&
          (!(pen > 0.0) || !segment_hits_bone(fields, x, x + pen * normal, bone_step))) {
        latch = kBoneFree;
      } else {
        if (!(pen > 0.0)) pen = 0.0;
        xc = x + pen * normal;  // held on the entry plane
        // The plane goes through the distance field's estimate of the entry point; on a curved,
        // voxelised bone it may cut into it: out along n while inside, by twice D_bone and
        // kHoldMargin (steps of D_bone alone, a lower bound of the way out, only approach the
        // surface), so the held point ends at most that much outside the bone.
        for (int k = 0; k < kHoldSteps; ++k) {
          const double d_in = fields.bone_value_at(xc);
          if (!(d_in > 0.0)) break;
          const double out = 2.0 * d_in + kHoldMargin;
          pen += out;
          xc += out * normal;
        }
        f_struct = (prm.bone_fmax + prm.bone_k * pen) * normal;
        k_struct = prm.bone_k;
        latched = true;
        status |= kTickBoneLatched;
      }
    }
    if (!latched) {
      // Bone along the skin normal: the distance to bone along -v_s.
      const double dist = -bone.value;
      const double cos_b = has_vb && has_dir ? dot(v_b, v_s) : 0.0;
      if (!inside_bone && dist > 0.0 && cos_b > 0.0) {
        // Along -v_s the bone is at least `dist` away; the map (prepared by Model) says how far.
        double reach = dist;
        if (prm.bone_along_normal && fields.beneath.value != nullptr)
          reach = std::max(dist, fields.beneath_at(x));
        const double fade =
            prm.bone_fade_mm > 0.0 ? smoothstep(skin_x.value / prm.bone_fade_mm) : 1.0;
        // the printed law f_b = 20 (x / 5)^-3 with its 5 mm scaled to bone_reach_mm
        const double scale = 5.0 / prm.bone_reach_mm;
        f_struct = (bone_force(reach * scale, prm.bone_fmax) * fade) * v_s;
        k_struct = bone_force_slope(reach * scale, prm.bone_fmax) * scale * fade;
      }
      if (!inside_bone && has_vb && cos_b > 0.0) {
        anchor = x + bone.value * v_b;
        normal = v_b;
        latch = kBoneAnchor;
      } else {
        latch = kBoneFree;
      }
    }
    st.bone_latch[i] = latch;
  }

  // Skin at the contact point (resampled where the proxy holds it off the device point).
  FieldSample skin = skin_x;
  if (latched) {
    skin = fields.surf_at(xc);
    v_s = skin_normal(skin, has_dir);
  }
  if (!has_dir) status |= kTickNoSkinDirection;
  const double depth = std::max(0.0, skin.value);
  double skin_slope = 0.0;
  const Vec3d f_surf = saturated_surface_force(depth, prm.skin_fmax, &skin_slope) * v_s;
  if (has_dir) st.normal[i] = v_s;

  // Surface point and Coulomb friction: the proxy on the tangent plane at s, at most
  // mu f_n / k from it.
  const Vec3d s = has_dir ? xc + depth * v_s : (entering ? xc : st.s[i]);
  const Vec3d s_last = entering ? s : st.s[i];
  const Vec3d p_last = entering ? s : st.p[i];
  const double f_n = std::max(0.0, dot(f_surf + f_struct, v_s));
  const double radius = prm.k > 0.0 ? prm.mu * f_n / prm.k : 0.0;
  Vec3d d = s - p_last;
  d = d - dot(d, v_s) * v_s;  // tangential
  const double dn = norm(d);
  const Vec3d p = dn <= radius ? s - d : s - (radius / dn) * d;
  const Vec3d f_friction = prm.k * (p - s);
  const Vec3d f = f_surf + f_friction + f_struct;
  if (!is_finite(f) || !is_finite(p) || !is_finite(s) || !is_finite(xc)) {
    status |= kTickNonFinite;
    clear_contact(st, i, x);
    st.normal[i] = Vec3d{};
    return;
  }
  // (a point held on the entry plane is checked there; a free one is outside bone, or it would
  // have latched, unless there was no direction to latch along)
  if (bone_on && (latched ? fields.bone_at(xc).value > 0.0 : inside_x)) status |= kTickInsideBone;

  st.in_contact[i] = 1;
  st.x[i] = xc;
  st.s_prev[i] = s_last;
  st.s[i] = s;
  st.p[i] = p;
  st.f[i] = f;
  st.f_friction[i] = f_friction;
  st.f_bone[i] = f_struct;
  st.depth[i] = depth;

  sums.f += f;
  sums.tau += cross(xc - xd, f);
  sums.u += p - xc;
  sums.k += skin_slope + k_struct + (dn <= radius ? prm.k : 0.0);
  ++sums.n;
}

template <class Access>
void tick_impl(const Access& fields, const ForceParams& prm, const std::vector<Vec3d>& points,
               State& st, const Pose& pose, double bone_step) {
  const bool pose_ok = pose_usable(pose);
  const Quat q = pose_ok ? normalized(pose.orientation) : Quat{};
  const Vec3d xd = pose_ok ? pose.position : Vec3d{};
  const bool bone_on = fields.has_bone && prm.bone_enabled;
  std::uint32_t status = pose_ok ? kTickOk : kTickBadPose;

  Vec3d f_sum{}, tau_sum{}, u_sum{};
  double k_sum = 0.0;
  int n_contact = 0;
  const bool palp = prm.model == ModelKind::Palp;
  TickSums sums;  // the palp model's
  const std::size_t n = points.size();
  for (std::size_t i = 0; i < n; ++i) {
    // Tool frame -> scene frame: x = x_device + R(q) x_tool.
    const Vec3d x = pose_ok ? xd + rotate(q, points[i]) : Vec3d{};
    if (palp) {
      if (pose_ok) {
        palp_point(fields, prm, st, i, x, xd, bone_on, bone_step, status, sums);
      } else {
        clear_contact(st, i, x);
        st.normal[i] = Vec3d{};
      }
      continue;
    }
    // Skin distance and gradient at x (outside the grid: not inside, far outside the body).
    const FieldSample skin = pose_ok ? fields.surf_at(x) : FieldSample{};
    if (pose_ok && !skin.inside) status |= kTickOutsideGrid;
    // (2) In contact iff D_surf(x) > 0; otherwise no force and the proxy is forgotten.
    if (!(skin.value > 0.0)) {
      clear_contact(st, i, x);
      continue;
    }
    const bool entering = st.in_contact[i] == 0;
    const double depth = skin.value;

    // (1) v_s = -grad D_surf / |grad D_surf|: out through the skin; zero if there is no direction.
    const double grad_norm = norm(skin.grad);
    const bool has_dir = grad_norm >= prm.grad_epsilon;
    if (!has_dir) status |= kTickNoSkinDirection;
    const Vec3d v_s = has_dir ? skin.grad * (-1.0 / grad_norm) : Vec3d{};

    // (3) f_surf = f_s(D_surf) v_s.
    const Vec3d f_surf = surface_force(depth) * v_s;

    // (4, 5) f_structures = f_b(-D_bone) d_bone / |d_bone|, d_bone never pointing into the skin.
    Vec3d f_struct{};
    double k_struct = 0.0;  // the bone term's slope (N/mm)
    if (bone_on) {
      const FieldSample bone = fields.bone_at(x);
      const double bone_grad_norm = norm(bone.grad);
      const bool has_vb = bone_grad_norm >= prm.grad_epsilon;
      const Vec3d v_b = has_vb ? bone.grad * (-1.0 / bone_grad_norm) : Vec3d{};
      const bool inside_bone = bone.value > 0.0;
      if (inside_bone) status |= kTickInsideBone;
      k_struct = bone_force_slope(-bone.value, prm.bone_fmax);
      if (prm.bone_mode == BoneMode::Printed) {
        f_struct = printed_bone_force(prm, bone, v_b, has_vb, v_s);
      } else {
        // Robust: the bone proxy (see force_model.hpp).
        std::uint8_t latch = entering ? std::uint8_t{kBoneFree} : st.bone_latch[i];
        Vec3d& anchor = st.bone_anchor[i];
        Vec3d& normal = st.bone_normal[i];
        if (latch != kBoneLatched) {
          const bool crossed = inside_bone || (latch == kBoneAnchor &&
                                               segment_hits_bone(fields, st.x[i], x, bone_step));
          if (crossed && latch == kBoneAnchor) {
            latch = kBoneLatched;
          } else if (crossed && (has_dir || has_vb)) {
            // No remembered surface: push out of the skin (or, without a skin direction, toward
            // the nearest bone surface).
            normal = has_dir ? v_s : v_b;
            anchor = x + bone.value * normal;
            latch = kBoneLatched;
          }
        }
        if (latch == kBoneLatched) {
          const double pen = dot(anchor - x, normal);
          // Let go above the entry plane, or outside bone with no bone back to that plane.
          if (!(pen > 0.0) ||
              (!inside_bone && !segment_hits_bone(fields, x, x + pen * normal, bone_step))) {
            latch = kBoneFree;
          } else {
            f_struct = (prm.bone_fmax + prm.bone_k * pen) * normal;
            k_struct = prm.bone_k;
            status |= kTickBoneLatched;
          }
        }
        if (latch != kBoneLatched) {
          f_struct = printed_bone_force(prm, bone, v_b, has_vb, v_s);
          // Remember the nearest bone surface point while on the skin side of the bone.
          if (!inside_bone && has_vb && dot(v_b, v_s) > 0.0) {
            anchor = x + bone.value * v_b;
            normal = v_b;
            latch = kBoneAnchor;
          } else {
            latch = kBoneFree;
          }
        }
        st.bone_latch[i] = latch;
      }
    }

    // (6) Surface point s = x + D_surf v_s (held at its last value when there is no direction);
    // a point entering contact starts with p = s and s_prev = s.
    const Vec3d s = has_dir ? x + depth * v_s : (entering ? x : st.s[i]);
    const Vec3d s_last = entering ? s : st.s[i];
    const Vec3d p_last = entering ? s : st.p[i];
    const Vec3d d = s - p_last;

    // (7) z_max = c max(0, f_n . v_s) + 1, z_stick = z_max - 1, f_n = f_surf + f_structures.
    const double fn_vs = dot(f_surf + f_struct, v_s);
    const double z_max = prm.c * std::max(0.0, fn_vs) + 1.0;
    const double z_stick = z_max - 1.0;

    // (8) alpha(|d|) = (1/z_max) z^8 / (z_stick^8 + z^8), as 1 / (z_max (1 + (z_stick/z)^8)).
    const double dist = norm(d);
    double alpha = 0.0;
    if (dist > 0.0) {
      const double r = z_stick / dist;
      const double r2 = r * r;
      const double r4 = r2 * r2;
      alpha = 1.0 / (z_max * (1.0 + r4 * r4));
    }

    // (9) Proxy: slip to z_max behind s past breakaway, else creep along d by |s_t - s_{t-1}|.
    const Vec3d p =
        alpha * dist > 1.0 ? s - (z_max / dist) * d : p_last + (norm(s - s_last) * alpha) * d;

    // (10) f_friction = k (p - s); f = f_surf + f_friction + f_structures.
    const Vec3d f_friction = prm.k * (p - s);
    const Vec3d f = f_surf + f_friction + f_struct;
    if (!is_finite(f) || !is_finite(p) || !is_finite(s)) {
      status |= kTickNonFinite;
      clear_contact(st, i, x);
      continue;
    }

    st.in_contact[i] = 1;
    st.x[i] = x;
    st.s_prev[i] = s_last;
    st.s[i] = s;
    st.p[i] = p;
    st.f[i] = f;
    st.f_friction[i] = f_friction;
    st.f_bone[i] = f_struct;
    st.depth[i] = depth;

    // (11) tau = (x - x_device) x f; sums for the means of (12) and (13).
    f_sum += f;
    tau_sum += cross(x - xd, f);
    u_sum += p - x;
    k_sum += surface_force_slope(depth) + k_struct + prm.k;
    ++n_contact;
  }

  if (palp) {
    f_sum = sums.f, tau_sum = sums.tau, u_sum = sums.u, k_sum = sums.k, n_contact = sums.n;
  }
  // (12, 13) Device force, torque and displacement u: means over the points in contact.
  const double inv = n_contact > 0 ? 1.0 / n_contact : 0.0;
  st.f_device = f_sum * inv;
  st.tau_device = tau_sum * inv;
  st.u = u_sum * inv;
  st.stiffness = std::isfinite(k_sum) ? k_sum * inv : 0.0;
  if (!is_finite(st.f_device) || !is_finite(st.tau_device) || !is_finite(st.u)) {
    status |= kTickNonFinite;
    st.f_device = st.tau_device = st.u = Vec3d{};
  }
  st.n_contact = n_contact;
  st.status = status;
  ++st.ticks;
}

}  // namespace

Model::Model(std::shared_ptr<const FieldSampler> fields, Tool tool, ForceParams params)
    : fields_(std::move(fields)), tool_(std::move(tool)), params_(params) {
  if (!fields_) throw UsageError("force model: no distance maps");
  if (tool_.points.empty())
    throw UsageError("force model: tool '" + tool_.name + "' has no points");
  validate(params_);
  if (params_.model == ModelKind::Palp && params_.bone_along_normal)
    fields_->prepare_bone_beneath();
}

Model::Model(std::shared_ptr<const FieldSampler> fields, Tool tool)
    : Model(std::move(fields), tool, default_params(tool.kind)) {}

State make_state(const Model& model) {
  State st;
  const std::size_t n = model.contact_count();
  st.x.assign(n, Vec3d{});
  st.s.assign(n, Vec3d{});
  st.s_prev.assign(n, Vec3d{});
  st.p.assign(n, Vec3d{});
  st.f.assign(n, Vec3d{});
  st.f_friction.assign(n, Vec3d{});
  st.f_bone.assign(n, Vec3d{});
  st.depth.assign(n, 0.0);
  st.in_contact.assign(n, 0);
  st.bone_anchor.assign(n, Vec3d{});
  st.bone_normal.assign(n, Vec3d{});
  st.bone_latch.assign(n, kBoneFree);
  st.normal.assign(n, Vec3d{});
  return st;
}

void reset(State& st) {
  std::fill(st.x.begin(), st.x.end(), Vec3d{});
  std::fill(st.s.begin(), st.s.end(), Vec3d{});
  std::fill(st.s_prev.begin(), st.s_prev.end(), Vec3d{});
  std::fill(st.p.begin(), st.p.end(), Vec3d{});
  std::fill(st.f.begin(), st.f.end(), Vec3d{});
  std::fill(st.f_friction.begin(), st.f_friction.end(), Vec3d{});
  std::fill(st.f_bone.begin(), st.f_bone.end(), Vec3d{});
  std::fill(st.depth.begin(), st.depth.end(), 0.0);
  std::fill(st.in_contact.begin(), st.in_contact.end(), std::uint8_t{0});
  std::fill(st.bone_anchor.begin(), st.bone_anchor.end(), Vec3d{});
  std::fill(st.bone_normal.begin(), st.bone_normal.end(), Vec3d{});
  std::fill(st.bone_latch.begin(), st.bone_latch.end(), std::uint8_t{kBoneFree});
  std::fill(st.normal.begin(), st.normal.end(), Vec3d{});
  st.f_device = st.tau_device = st.u = Vec3d{};
  st.stiffness = 0.0;
  st.n_contact = 0;
  st.status = kTickOk;
  st.ticks = 0;
}

void tick(const Model& model, State& state, const Pose& device_pose) {
  const std::size_t n = model.contact_count();
  if (state.x.size() != n || state.s.size() != n || state.s_prev.size() != n ||
      state.p.size() != n || state.f.size() != n || state.f_friction.size() != n ||
      state.depth.size() != n || state.in_contact.size() != n || state.f_bone.size() != n ||
      state.bone_anchor.size() != n || state.bone_normal.size() != n ||
      state.bone_latch.size() != n || state.normal.size() != n) {
    // Not a State of this model: touch nothing per contact, report nothing.
    state.f_device = state.tau_device = state.u = Vec3d{};
    state.stiffness = 0.0;
    state.n_contact = 0;
    state.status = kTickBadState;
    return;
  }
  // Scheme and storage are chosen here, once per tick; the loop inside is monomorphic.
  const double bone_step = 0.5 * model.fields().grid().min_spacing();
  model.fields().dispatch([&](const auto& access) {
    tick_impl(access, model.params(), model.tool().points, state, device_pose, bone_step);
  });
}

}  // namespace palp
