#include "model/force_model.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "base/errors.hpp"
#include "model/tick_stages.hpp"

namespace palp {
namespace {

using namespace tick_stages;

// The paper model at one contact point: the spec's equations 1-11 as printed, the bone by the
// printed law or (Robust bone mode) the bone proxy.
template <class Access>
[[gnu::noinline]] void paper_point(const Access& fields, TickRun& run, State& st, std::size_t i,
                                   PointWork& w) {
  const ForceParams& prm = *run.prm;
  sample_skin(fields, run, w);           // x -> D_surf
  if (!skin_contact(st, i, w)) return;   // D_surf <= 0: out of contact
  skin_direction(prm, st, i, false, w);  // grad D_surf -> v_s
  flag_skin_direction(run, w);           //   (none: kTickNoSkinDirection)
  skin_force_printed(w);                 // D_surf -> f_surf (eq. 3)
  if (run.bone_on) {
    sample_bone(fields, prm, w);  // x -> D_bone, v_b
    if (w.inside_bone) run.status |= kTickInsideBone;
    w.k_struct = bone_force_slope(-w.bone.value, prm.bone_fmax);
    if (prm.bone_mode == BoneMode::Printed) {
      bone_law_printed(prm, w);  // D_bone, v_b, v_s -> f_struct (eqs. 4-5)
    } else if (!bone_proxy(fields, run, kPaperBoneProxy, st, i, w)) {  // held: f_struct
      bone_law_printed(prm, w);                                        // free: the printed law
      bone_proxy_remember(st, i, w);  //   and the bone surface beneath
    }
  }
  surface_point(st, i, w);      // x, D_surf, v_s -> s (eq. 6)
  friction_paper(prm, w);       // s, p_last, f_n -> p, f_friction (7-10)
  commit_point(run, st, i, w);  // -> State[i], sums (eq. 11)
}

// The palp model at one contact point (force_model.hpp, "Two models"): the bone proxy always, the
// bone felt along the skin normal and faded in with depth, the saturated skin law, the last
// normal past the band, and Coulomb friction placed from positions.
template <class Access>
[[gnu::noinline]] void palp_point(const Access& fields, TickRun& run, State& st, std::size_t i,
                                  PointWork& w) {
  const ForceParams& prm = *run.prm;
  sample_skin_and_bone(fields, run, w);  // x -> D_surf, D_bone (one pass)
  if (!skin_contact(st, i, w)) return;   // D_surf <= 0: out of contact
  skin_direction(prm, st, i, true, w);   // grad D_surf (or last normal) -> v_s
  if (run.bone_on) {
    bone_direction(prm, w);                                    // D_bone -> v_b, inside
    if (!bone_proxy(fields, run, kPalpBoneProxy, st, i, w)) {  // held: xc, f_struct
      bone_along_normal(fields, prm, w);  // bone beneath along -v_s -> f_struct
      bone_proxy_remember(st, i, w);      //   and the bone surface beneath
    }
  }
  resample_skin_at_contact(fields, prm, st, i, w);  // held off x: xc -> D_surf, v_s
  flag_skin_direction(run, w);                      //   (none: kTickNoSkinDirection)
  skin_force_saturated(prm, st, i, w);              // D_surf -> f_surf, kept normal
  layer_forces(run, w);                             // layers: f_n -> f_organ, f_pulse
  surface_point(st, i, w);                          // xc, D_surf, v_s -> s
  friction_coulomb(prm, w);                         // s, p_last, f_n -> p, f_friction
  if (!commit_point(run, st, i, w)) return;         // -> State[i], sums
  // (a held point is checked where it is held; a free one is outside bone, or it would have
  // latched, unless there was no direction to latch along)
  if (run.bone_on && (w.latched ? fields.bone_at(w.xc).value > 0.0 : w.inside_bone))
    run.status |= kTickInsideBone;
}

template <class Access>
void tick_impl(const Access& fields, const Model& model, State& st, const Pose& pose,
               double bone_step) {
  const ForceParams& prm = model.params();
  const std::vector<Vec3d>& points = model.tool().points;
  TickRun run = begin_tick(prm, fields.has_bone, bone_step, pose);  // pose -> q, x_device
  const bool palp = prm.model == ModelKind::Palp;
  if (palp) {  // the layers and this tick's pulse (the paper model has none)
    run.layers = model.layers().data();
    run.n_layers = model.layers().size();
    run.pulse_wave = st.pulse_wave;
  }
  PointWork w;
  for (std::size_t i = 0; i < points.size(); ++i) {
    begin_point(place_point(run, points[i]), w);  // tool frame -> scene frame
    if (!run.pose_ok) {
      drop_point(st, i, w.x);  // unusable pose: nothing in contact
    } else if (palp) {
      palp_point(fields, run, st, i, w);
    } else {
      paper_point(fields, run, st, i, w);
    }
  }
  device_outputs(run, st);  // sums -> f_device, tau, u (eqs. 12-13)
}

// The pulse's clock: the phase advances by the time since the last tick times bpm / 60 (held on
// the first tick, a step back, a non-finite time or rate) -> pulse_phase, pulse_wave.
void advance_pulse_clock(State& st, double time_s) {
  if (std::isfinite(time_s)) {
    const double dt = st.clock_started ? time_s - st.time_s : 0.0;
    const double bpm = std::isfinite(st.pulse_bpm) ? std::clamp(st.pulse_bpm, 0.0, 240.0) : 0.0;
    if (dt > 0.0 && dt < 1.0e6) {
      st.pulse_phase += dt * bpm / 60.0;
      st.pulse_phase -= std::floor(st.pulse_phase);
    }
    if (!st.clock_started || dt > 0.0) st.time_s = time_s;
    st.clock_started = true;
  }
  st.pulse_wave = st.pulse_bpm > 0.0 ? pulse_waveform(st.pulse_phase) : 0.0;
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

Model::Model(std::shared_ptr<const FieldSampler> fields, Tool tool, ForceParams params,
             std::vector<StructureLayer> layers)
    : Model(std::move(fields), std::move(tool), params) {
  for (const StructureLayer& layer : layers)
    if (!layer.map)
      throw UsageError("force model: structure layer '" + layer.name + "' has no map");
  layers_ = std::move(layers);
  pulse_waveform(0.0);  // its table is built here, not in the first tick
}

State make_state(const Model& model) {
  State st = make_state(model.contact_count());
  st.pulse_bpm = model.params().pulse_bpm;
  return st;
}

State make_state(std::size_t n) {
  State st;
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
  st.f_pulse = st.f_organ = Vec3d{};
  st.pulse_phase = st.pulse_wave = st.time_s = 0.0;
  st.clock_started = false;
  st.n_contact = 0;
  st.status = kTickOk;
  st.ticks = 0;
}

void tick(const Model& model, State& state, const Pose& device_pose) {
  tick(model, state, device_pose, state.clock_started ? state.time_s : 0.0);
}

void tick(const Model& model, State& state, const Pose& device_pose, double time_s) {
  const std::size_t n = model.contact_count();
  if (state.x.size() != n || state.s.size() != n || state.s_prev.size() != n ||
      state.p.size() != n || state.f.size() != n || state.f_friction.size() != n ||
      state.depth.size() != n || state.in_contact.size() != n || state.f_bone.size() != n ||
      state.bone_anchor.size() != n || state.bone_normal.size() != n ||
      state.bone_latch.size() != n || state.normal.size() != n) {
    // Not a State of this model: touch nothing per contact, report nothing.
    state.f_device = state.tau_device = state.u = Vec3d{};
    state.stiffness = 0.0;
    state.f_pulse = state.f_organ = Vec3d{};
    state.n_contact = 0;
    state.status = kTickBadState;
    return;
  }
  advance_pulse_clock(state, time_s);  // time -> phase, wave
  // Scheme and storage are chosen here, once per tick; the loop inside is monomorphic.
  const double bone_step = 0.5 * model.fields().grid().min_spacing();
  model.fields().dispatch(
      [&](const auto& access) { tick_impl(access, model, state, device_pose, bone_step); });
}

}  // namespace palp
