// SceneInfo, render volume chunks and Stats for palpd's clients: see scene_messages.hpp.
#include "net/scene_messages.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <string>
#include <vector>

#include "net/protocol.hpp"
#include "prep/maps/map_refine.hpp"
#include "safety/virtual_coupling.hpp"
#include "wire/messages.hpp"
#include "wire/volume_codec.hpp"

namespace palp::net {

void fill_scene_info(const SceneDescription& scene, const rt::HapticLoop& loop, v1::SceneInfo* si) {
  si->set_source(scene.source);
  v1::Grid* g = si->mutable_grid();
  for (int a = 0; a < 3; ++a) {
    g->add_dims(scene.grid.dims[a]);
    g->add_spacing(scene.grid.spacing[a]);
    g->add_origin(scene.grid.world.origin[a]);
  }
  for (double d : scene.grid.world.direction) g->add_direction(d);
  for (const auto& [k, v] : scene.metadata) (*si->mutable_metadata())[k] = v;
  const std::shared_ptr<const Model> model = loop.model();
  v1::ToolInfo* tool = si->mutable_tool();
  tool->set_name(model->tool().name);
  for (const Vec3d& p : model->tool().points) wire::to_proto(p, tool->add_points());
  const ForceParams& fp = model->params();
  v1::Parameters* p = si->mutable_parameters();
  p->set_c(fp.c);
  p->set_k(fp.k);
  p->set_bone_fmax(fp.bone_fmax);
  p->set_bone_flip(fp.bone_flip);
  p->set_bone_enabled(fp.bone_enabled);
  p->set_bone_mode(to_string(fp.bone_mode));
  p->set_bone_k(fp.bone_k);
  p->set_model(to_string(fp.model));
  p->set_mu(fp.mu);
  p->set_skin_fmax_n(fp.skin_fmax);
  p->set_bone_fade_mm(fp.bone_fade_mm);
  p->set_bone_along_normal(fp.bone_along_normal);
  p->set_bone_reach_mm(fp.bone_reach_mm);
  p->set_pulse_bpm(loop.pulse_bpm());  // the loop's, which SetParameter pulse_bpm changes
  si->set_device(scene.device);
  si->set_device_profile(scene.device_profile);
  si->set_device_renders_force(loop.device().renders_force());
  si->set_tick_rate_hz(loop.config().rate_hz);
  if (const DeviceProfile* profile = loop.config().profile) {
    v1::ForceLimits* l = si->mutable_limits();
    l->set_profile(std::string(profile->name));
    l->set_max_force_n(profile->max_force_N);
    l->set_max_stiffness_n_per_mm(profile->max_stiffness_N_per_mm);
    l->set_max_force_rate_n_per_s(profile->max_force_rate_N_per_s);
    if (loop.config().engage) {
      l->set_engage_threshold_n(loop.config().engage->threshold_N);
      l->set_engage_ramp_s(loop.config().engage->ramp_s);
    }
    if (loop.config().passivity) l->set_max_damping_n_s_per_mm(profile->damping_N_s_per_mm);
    if (loop.config().coupling) {
      const CouplingGains gains = coupling_gains(*profile, 1.0 / loop.config().rate_hz);
      l->set_coupling_stiffness_n_per_mm(gains.stiffness_N_per_mm);
      l->set_coupling_damping_n_s_per_mm(gains.damping_N_s_per_mm);
    }
  }
  if (scene.structures)
    for (const StructureLabel& l : scene.structures->structures) {
      v1::Structure* st = si->add_structures();
      st->set_label(l.label);
      st->set_name(l.name);
      st->set_kind(l.kind);
    }
  if (scene.placement) {
    const SceneDescription::Placement& pl = *scene.placement;
    v1::Registration* r = si->mutable_registration();
    for (double v : pl.registration.rotation) r->add_rotation(v);
    r->set_scale(pl.registration.scale);
    wire::to_proto(pl.registration.home, r->mutable_home());
    r->add_workspace_half_mm(pl.workspace_half_mm.x);
    r->add_workspace_half_mm(pl.workspace_half_mm.y);
    r->add_workspace_half_mm(pl.workspace_half_mm.z);
    r->set_home_site(pl.home_site);
    r->set_axes(pl.axes);
    wire::to_proto(pl.home_skin, r->mutable_home_skin());
  }
}

VolumePlan plan_volume(const SceneDescription& scene, const VolumeRequest& request,
                       std::size_t chunk_bytes, const VoxelBox* crop) {
  VolumePlan plan;
  const Grid& grid = scene.grid;
  const Index3 dims = grid.dims;
  plan.hu = request.hu && scene.ct && scene.body && scene.body->grid.dims == scene.ct->grid.dims &&
            refinement_between(scene.ct->grid, grid)[0] != 0;  // the maps' grid or one they refine
  plan.bone = request.bone && scene.fields->has_bone();
  plan.deflate = request.deflate;
  plan.labels = request.labels && scene.structures && !scene.structures->structures.empty() &&
                refinement_between(scene.structures->labels.grid, grid)[0] != 0;
  plan.voxel_bytes = sizeof(float) * (plan.bone ? 2 : 1) + (plan.hu ? 3 : 0) + (plan.labels ? 1 : 0);
  // The box that goes out: the whole grid, or the crop (clamped to the grid).
  VoxelBox box{{0, 0, 0}, {dims[0], dims[1], dims[2]}};
  if (request.crop && plan.hu && crop && !crop->empty()) {
    const Refinement r = refinement_between(scene.ct->grid, grid);  // the crop is in CT voxels
    for (int a = 0; a < 3; ++a) {
      box.lo[a] = std::clamp<std::int64_t>(crop->lo[a] * r[a], 0, dims[a] - 1);
      box.hi[a] = std::clamp<std::int64_t>((crop->hi[a] - 1) * r[a] + 1, box.lo[a] + 1, dims[a]);
    }
  }
  // Sampled voxels along axis a at step s: from lo aligned down to s, every s-th below hi.
  const auto extent = [&](int a, std::uint32_t s) {
    const std::int64_t lo = box.lo[a] / s * s;
    return (box.hi[a] - lo + s - 1) / s;
  };
  std::uint32_t step = request.step;
  if (step == 0) {
    const std::int64_t largest =
        std::max({box.hi[0] - box.lo[0], box.hi[1] - box.lo[1], box.hi[2] - box.lo[2]});
    step = static_cast<std::uint32_t>((largest + request.max_dim - 1) / request.max_dim);
    step = std::clamp<std::uint32_t>(step, 1, 1024);
    // Maps on a refinement of the CT's grid: by default no finer than the CT (its nodes).
    if (const Refinement r = scene.ct ? refinement_between(scene.ct->grid, grid) : Refinement{};
        r[0] > 0)
      step =
          std::max<std::uint32_t>(step, static_cast<std::uint32_t>(std::min({r[0], r[1], r[2]})));
    // The alignment can add one voxel: coarser until every axis is within max_dim.
    while (step < 1024 && std::max({extent(0, step), extent(1, step), extent(2, step)}) >
                              static_cast<std::int64_t>(request.max_dim))
      ++step;
  }
  step = std::clamp<std::uint32_t>(step, 1, 1024);
  // One slice must fit a chunk whatever was asked: coarser until it does.
  const auto slice_bytes = [&](std::uint32_t s) {
    return static_cast<std::size_t>(extent(0, s) * extent(1, s)) * plan.voxel_bytes;
  };
  while (step < 1024 && slice_bytes(step) > kMaxChunkRawBytes) ++step;
  plan.step = step;
  for (int a = 0; a < 3; ++a) {
    plan.offset[a] = box.lo[a] / step * step;
    plan.dims[a] = extent(a, step);
  }
  plan.slab = static_cast<std::uint32_t>(
      std::max<std::size_t>(1, chunk_bytes / std::max<std::size_t>(1, slice_bytes(step))));
  plan.chunks = static_cast<std::uint32_t>((plan.dims[2] + plan.slab - 1) / plan.slab);
  return plan;
}

VoxelBox body_box(const Mask& body, double margin_mm) {
  const Index3 d = body.grid.dims;
  VoxelBox box{{d[0], d[1], d[2]}, {0, 0, 0}};
  for (std::int64_t k = 0; k < d[2]; ++k)
    for (std::int64_t j = 0; j < d[1]; ++j) {
      const std::uint8_t* row = &body.data[static_cast<std::size_t>(d[0] * (j + d[1] * k))];
      std::int64_t first = 0;
      while (first < d[0] && row[first] == 0) ++first;
      if (first == d[0]) continue;
      std::int64_t last = d[0] - 1;
      while (row[last] == 0) --last;
      box.lo = {std::min(box.lo[0], first), std::min(box.lo[1], j), std::min(box.lo[2], k)};
      box.hi = {std::max(box.hi[0], last + 1), std::max(box.hi[1], j + 1),
                std::max(box.hi[2], k + 1)};
    }
  if (box.empty()) return {};
  for (int a = 0; a < 3; ++a) {
    const auto m = static_cast<std::int64_t>(std::ceil(margin_mm / body.grid.spacing[a]));
    box.lo[a] = std::max<std::int64_t>(0, box.lo[a] - m);
    box.hi[a] = std::min<std::int64_t>(d[a], box.hi[a] + m);
  }
  return box;
}

namespace {
std::string as_bytes(const void* data, std::size_t n, bool deflate) {
  std::string raw(static_cast<const char*>(data), n);
  return deflate ? wire::deflate_bytes(raw) : raw;
}

// The chunk's structure labels: at each sampled voxel the labels' nearest node.
std::string chunk_labels(const SceneDescription& scene, const VolumePlan& plan,
                         std::uint32_t k_begin, std::uint32_t k_count) {
  const Mask& labels = scene.structures->labels;
  const Refinement r = refinement_between(labels.grid, scene.grid);
  std::string out(static_cast<std::size_t>(plan.dims[0] * plan.dims[1]) * k_count, '\0');
  const std::int64_t st = plan.step;
  std::size_t v = 0;
  for (std::uint32_t k = 0; k < k_count; ++k)
    for (std::int64_t j = 0; j < plan.dims[1]; ++j)
      for (std::int64_t i = 0; i < plan.dims[0]; ++i, ++v)
        out[v] = static_cast<char>(label_at(labels, r, plan.offset[0] + i * st,
                                            plan.offset[1] + j * st,
                                            plan.offset[2] + (k_begin + k) * st));
  return plan.deflate ? wire::deflate_bytes(out) : out;
}
}  // namespace

std::uint32_t fill_volume_chunk(const SceneDescription& scene, const VolumePlan& plan,
                                std::uint32_t k_begin, std::uint32_t index, v1::VolumeChunk* c) {
  const FieldSampler& fields = *scene.fields;
  const Grid& grid = scene.grid;
  const std::uint32_t k_count =
      std::min<std::uint32_t>(plan.slab, static_cast<std::uint32_t>(plan.dims[2]) - k_begin);
  const std::size_t n = static_cast<std::size_t>(plan.dims[0] * plan.dims[1]) * k_count;
  std::vector<float> surf(n), bone(plan.bone ? n : 0);
  std::vector<std::int16_t> hu(plan.hu ? n : 0);
  std::vector<std::uint8_t> body(plan.hu ? n : 0);
  const Vec3 sp = grid.spacing;
  const std::int64_t st = plan.step;
  // HU and body from the CT's nearest node when the maps refine its grid
  // (prep/maps/map_refine.hpp).
  const Refinement r = plan.hu ? refinement_between(scene.ct->grid, grid) : Refinement{1, 1, 1};
  const Index3 ct_dims = plan.hu ? scene.ct->grid.dims : grid.dims;
  std::size_t v = 0;
  for (std::uint32_t k = 0; k < k_count; ++k)
    for (std::int64_t j = 0; j < plan.dims[1]; ++j)
      for (std::int64_t i = 0; i < plan.dims[0]; ++i, ++v) {
        const std::int64_t gi = plan.offset[0] + i * st, gj = plan.offset[1] + j * st,
                           gk = plan.offset[2] + (k_begin + k) * st;
        const Vec3d x{static_cast<double>(gi) * sp[0], static_cast<double>(gj) * sp[1],
                      static_cast<double>(gk) * sp[2]};
        surf[v] = static_cast<float>(fields.sample_surf(x).value);
        if (plan.bone) bone[v] = static_cast<float>(fields.sample_bone(x).value);
        if (plan.hu) {
          const std::int64_t ci = (gi + r[0] / 2) / r[0], cj = (gj + r[1] / 2) / r[1],
                             ck = (gk + r[2] / 2) / r[2];
          const auto g = static_cast<std::size_t>(ci + ct_dims[0] * (cj + ct_dims[1] * ck));
          hu[v] = scene.ct->data[g];
          body[v] = scene.body->data[g] ? 1 : 0;
        }
      }
  if constexpr (std::endian::native == std::endian::big)
    for (std::int16_t& h : hu)
      h = static_cast<std::int16_t>(__builtin_bswap16(static_cast<std::uint16_t>(h)));
  c->set_step(plan.step);
  for (int a = 0; a < 3; ++a) {
    c->add_dims(plan.dims[a]);
    c->add_spacing(sp[a] * plan.step);
  }
  if (plan.offset != std::array<std::int64_t, 3>{})
    for (int a = 0; a < 3; ++a) c->add_offset(plan.offset[a]);
  c->set_k_begin(k_begin);
  c->set_k_count(k_count);
  c->set_deflate(plan.deflate);
  c->set_d_surf(as_bytes(surf.data(), surf.size() * sizeof(float), plan.deflate));
  if (plan.bone) c->set_d_bone(as_bytes(bone.data(), bone.size() * sizeof(float), plan.deflate));
  if (plan.hu) {
    c->set_hu(as_bytes(hu.data(), hu.size() * sizeof(std::int16_t), plan.deflate));
    c->set_body(as_bytes(body.data(), body.size(), plan.deflate));
  }
  if (plan.labels) c->set_labels(chunk_labels(scene, plan, k_begin, k_count));
  c->set_chunk_index(index);
  c->set_chunk_count(plan.chunks);
  return k_count;
}

void fill_stats(const rt::LoopStats& ls, const rt::HapticLoop& loop, const SceneDescription& scene,
                const ControlTarget* control, double rate_hz, std::int64_t now_ns,
                std::uint32_t clients, v1::Stats* st) {
  st->set_server_time_ns(now_ns);
  st->set_target_rate_hz(loop.config().rate_hz);
  st->set_rate_hz(rate_hz);
  st->set_ticks(ls.ticks);
  st->set_overruns(ls.overruns);
  st->set_faults(ls.faults);
  for (double b : rt::kJitterBucketUpperUs) st->add_jitter_bucket_upper_us(b);
  for (std::uint64_t c : ls.jitter) st->add_jitter_counts(c);
  st->set_jitter_max_us(static_cast<double>(ls.max_late_ns) * 1e-3);
  st->set_tick_mean_us(
      ls.ticks ? static_cast<double>(ls.tick_ns_sum) * 1e-3 / static_cast<double>(ls.ticks) : 0.0);
  st->set_tick_max_us(static_cast<double>(ls.tick_ns_max) * 1e-3);
  st->set_clients(clients);
  st->set_frames_published(ls.net_published);
  st->set_frames_lost(ls.net_dropped);
  st->set_realtime(ls.realtime);
  st->set_recording(control ? control->recording() : ls.recording);
  st->set_record_lost(control ? control->record_lost() : ls.record_dropped);
  st->set_paused(ls.paused);
  st->set_last_fault(ls.last_fault);
  st->set_device_state(to_proto(ls.device_state));
  st->set_device_message(loop.device().status_message());
  if (scene.placement) wire::to_proto(loop.registration_home(), st->mutable_registration_home());
  st->set_recentres(ls.recentres);
  const DeclaredLimits declared = loop.device().declared_limits();
  st->set_declared_max_force_n(declared.max_force_N);
  st->set_declared_max_stiffness_n_per_mm(declared.max_stiffness_N_per_mm);
  st->set_declared_damping_n_s_per_mm(declared.damping_N_s_per_mm);
  st->set_engage_gain(ls.engage_gain);
  st->set_passivity_ticks(ls.passivity_ticks);
  st->set_passivity_dissipated_mj(ls.passivity_dissipated_mJ);
  st->set_wake_mode(rt::to_string(ls.wake.mode));
  for (std::uint64_t c : ls.wake.latency) st->add_wake_latency_counts(c);
  st->set_wake_latency_max_us(static_cast<double>(ls.wake.latency_max_ns) * 1e-3);
  st->set_spin_window_us(static_cast<double>(ls.wake.spin_window_ns) * 1e-3);
  const double running = static_cast<double>(ls.running_ns);
  st->set_spin_cpu_fraction(running > 0 ? static_cast<double>(ls.wake.spin_ns) / running : 0.0);
  st->set_loop_cpu_fraction(ls.loop_cpu_wall_ns > 0 ? static_cast<double>(ls.loop_cpu_ns) /
                                                          static_cast<double>(ls.loop_cpu_wall_ns)
                                                    : 0.0);
  const rt::DeviceLinkCounters link = loop.device().link_counters();
  st->set_device_exchanges(link.exchanges);
  st->set_device_corrupt_frames(link.corrupt);
  st->set_device_short_frames(link.short_frames);
  st->set_device_lost_replies(link.lost_replies);
  st->set_device_force_limited(link.force_limited);
  if (const auto it = scene.metadata.find("tuning"); it != scene.metadata.end())
    st->set_tuning(it->second);
  if (const auto it = scene.metadata.find("tuning_note"); it != scene.metadata.end())
    st->set_tuning_note(it->second);
  if (const auto it = scene.metadata.find("maps"); it != scene.metadata.end())
    st->set_maps(it->second);
}

}  // namespace palp::net
