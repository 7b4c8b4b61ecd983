// The haptic loop: see haptic_loop.hpp.
#include "loop/haptic_loop.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <system_error>

#include "base/errors.hpp"
#include "loop/atomic_max.hpp"

namespace palp::rt {
namespace {

std::size_t contact_capacity_for(const LoopConfig& config, const Model& model) {
  if (config.contact_capacity > 0) return config.contact_capacity;
  return std::max<std::size_t>(model.contact_count(), 64);
}

std::int64_t period_for(double rate_hz) {
  if (!(rate_hz >= 1.0 && rate_hz <= 100000.0))
    throw UsageError("--rate must be between 1 and 100000 Hz");
  return static_cast<std::int64_t>(1e9 / rate_hz + 0.5);
}

std::string pct_text(double q) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", q * 100);
  return text;
}

std::string us_text(std::int64_t ns) {
  return std::to_string((ns + 500) / 1000) + " us";
}

}  // namespace

std::string pulse_bpm_refusal(double bpm) {
  if (bpm >= 0.0 && bpm <= kMaxPulseBpm) return {};
  return "pulse_bpm must be in [0, 240] beats per minute (0: no pulse)";
}

void HapticLoop::set_pulse_bpm(double bpm) {
  if (const std::string why = pulse_bpm_refusal(bpm); !why.empty()) throw UsageError(why);
  pulse_bpm_.store(bpm, std::memory_order_relaxed);
}

HapticLoop::HapticLoop(std::shared_ptr<const Model> model, Device& device, LoopConfig config)
    : config_(config),
      device_(device),
      period_ns_(period_for(config.rate_hz)),
      dt_s_(0.0),
      net_ring_(config.net_slots, model ? contact_capacity_for(config, *model) : 64),
      record_ring_(config.record_slots, 0),
      waker_(config.wake, period_ns_, system_clock()) {
  if (!model) throw UsageError("haptic loop: no model");
  dt_s_ = static_cast<double>(period_ns_) * 1e-9;
  current_ = std::make_unique<Bundle>(Bundle{model, make_state(*model)});
  set_pulse_bpm(model->params().pulse_bpm);
  requested_ = std::move(model);
  device_state_.store(static_cast<std::uint8_t>(device_.state()), std::memory_order_relaxed);
  registration_ = config.registration;
  chain_config_.engage = config.engage;
  chain_config_.passivity = config.passivity;
  chain_config_.coupling = config.coupling;
  identity_ = registration_.is_identity();
  for (int a = 0; a < 3; ++a)
    home_[static_cast<std::size_t>(a)].store(a == 0   ? registration_.home.x
                                             : a == 1 ? registration_.home.y
                                                      : registration_.home.z);
}

Vec3d HapticLoop::registration_home() const {
  return {home_[0].load(std::memory_order_relaxed), home_[1].load(std::memory_order_relaxed),
          home_[2].load(std::memory_order_relaxed)};
}

HapticLoop::~HapticLoop() {
  stop();
  delete pending_.exchange(nullptr);
  delete retired_.exchange(nullptr);
}

void HapticLoop::start() {
  if (thread_.joinable()) return;
  stop_.store(false);
  setup_.store(0);
  try {
    thread_ = std::thread([this] { run(); });
  } catch (const std::system_error& e) {
    throw ResourceError(std::string("cannot start the haptic thread: ") + e.what());
  }
  realtime_report_ = realtime_setup();
  // the thread calibrates its wake-up once set up (at most 0.1 s); its outcome goes in the report
  setup_.store(1, std::memory_order_release);
  for (int i = 0; i < 2000 && setup_.load(std::memory_order_acquire) != 2; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  const WakeStats w = waker_.stats();
  realtime_report_ += std::string("; wake-up: ") + to_string(w.mode);
  if (w.mode == WakeMode::Hybrid) {
    realtime_report_ += ", spin window " + us_text(w.spin_window_ns);
    if (config_.wake.spin_us > 0)
      realtime_report_ += " (--spin-us)";
    else
      realtime_report_ += " (wake-up latency p" + pct_text(config_.wake.quantile) + " " +
                          us_text(w.calibrated_quantile_ns) +
                          " measured at start, adapted as the loop runs)";
    if (!slack_report_.empty()) realtime_report_ += ", " + slack_report_;
  }
}

std::string HapticLoop::realtime_setup() {
  std::string report;
  if (config_.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(config_.cpu, &set);
    const int rc = pthread_setaffinity_np(thread_.native_handle(), sizeof set, &set);
    report = rc == 0 ? "loop thread pinned to CPU " + std::to_string(config_.cpu) + "; "
                     : "warning: cannot pin the loop thread to CPU " + std::to_string(config_.cpu) +
                           " (" + std::strerror(rc) + "); ";
  }
  if (!config_.realtime) return report + "real-time scheduling not requested (--no-realtime)";
  sched_param param{};
  param.sched_priority = config_.priority;
  const int sched_rc = pthread_setschedparam(thread_.native_handle(), SCHED_FIFO, &param);
  const int lock_rc = mlockall(MCL_CURRENT) == 0 ? 0 : errno;
  realtime_.store(sched_rc == 0 && lock_rc == 0, std::memory_order_relaxed);
  if (realtime_.load(std::memory_order_relaxed))
    return report + "real time: SCHED_FIFO priority " + std::to_string(config_.priority) +
           ", memory locked";
  std::string warning = "warning: running without real-time guarantees:";
  if (sched_rc != 0)
    warning += " SCHED_FIFO refused (" + std::string(std::strerror(sched_rc)) +
               "; needs CAP_SYS_NICE or an rtprio limit);";
  if (lock_rc != 0)
    warning += " mlockall refused (" + std::string(std::strerror(lock_rc)) +
               "; needs CAP_IPC_LOCK or a memlock limit);";
  warning += " expect more jitter";
  // a warning leads the report (palpd prints those even with --quiet)
  return report.rfind("warning", 0) == 0 ? report + warning.substr(9) : warning + "; " + report;
}

void HapticLoop::stop() {
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
  device_.write(DeviceCommand{});
  collect_retired();
}

void HapticLoop::run() {
  while (setup_.load(std::memory_order_acquire) == 0 && !stop_.load(std::memory_order_acquire))
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  // Hybrid: no timer slack on the sleep before the spin (the plain sleep mode stays as it was).
  if (config_.wake.mode == WakeMode::Hybrid) slack_report_ = minimise_timer_slack();
  waker_.calibrate();
  setup_.store(2, std::memory_order_release);
  DeadlineTicker ticker(period_ns_, waker_);
  const std::int64_t cpu0 = thread_cpu_ns();
  started_ns_.store(monotonic_ns(), std::memory_order_relaxed);
  ticker.start(monotonic_ns() + period_ns_);
  std::uint32_t since_cpu = 0;
  while (!stop_.load(std::memory_order_acquire)) {
    const DeadlineTicker::Due due = ticker.wait();
    step(due.deadline_ns, due.now_ns);
    if (const std::uint64_t missed = ticker.finish(monotonic_ns()))
      overruns_.fetch_add(missed, std::memory_order_relaxed);
    if (++since_cpu == 256) {
      since_cpu = 0;
      sample_cpu(cpu0);
    }
  }
  sample_cpu(cpu0);
}

void HapticLoop::sample_cpu(std::int64_t cpu0) noexcept {
  loop_cpu_ns_.store(thread_cpu_ns() - cpu0, std::memory_order_relaxed);
  loop_cpu_wall_ns_.store(monotonic_ns() - started_ns_.load(std::memory_order_relaxed),
                          std::memory_order_relaxed);
}

// One tick's values, handed from stage to stage (the state that outlives the tick - the last pose,
// the force chain, the registration - stays in the loop's members).
struct HapticLoop::Tick {
  Tick(std::int64_t deadline, std::int64_t late) noexcept : deadline_ns(deadline), late_ns(late) {}
  std::int64_t deadline_ns = 0;
  std::int64_t late_ns = 0;  // start - deadline
  std::uint32_t zero = 0;    // LoopFault bits: why the force is zeroed (0: it is not)
  DeviceState device_state = DeviceState::Present;  // what the snapshot says of the device
  Vec3d force{}, torque{};                          // device frame, as the force chain left them
  Vec3d active{};  // the model's known active force (the pulse, part of force), device frame
  std::uint32_t safety = kSafetyOk;
  TickRecord rec;
  const State* state = nullptr;  // contacts to publish: set when the force was written
};

// The chain named in haptic_loop.hpp, one stage a line (in the shape of MuJoCo's mj_step).
void HapticLoop::step(std::int64_t deadline_ns, std::int64_t now_ns) noexcept {
  const std::int64_t begin = monotonic_ns();
  Tick t(deadline_ns, now_ns - deadline_ns);
  swap_in_pending_model();        // pending_ -> current_ (the old one to retired_)
  apply_record_request();         // record_request_ -> recording_on_ (a start resets state)
  count_lateness(t.late_ns);      // lateness -> jitter_ histogram, max_late_ns_
  t.zero |= watchdog(t.late_ns);  // too late -> kFaultDeadline, device zeroed at once
  if (!read_device(t)) return;    // device -> last_pose_, have_pose_, t.zero (false: Finished)
  recentre();                     // recentre_request_, last_device_pose_ -> registration_
  t.device_state = device_presence(t.zero);  // t.zero, device state -> device_state_, unplugs
  t.zero |= idle_bits(have_pose_, paused_.load(std::memory_order_relaxed));  // no pose, paused
  begin_record(t);                          // seq_, deadline, lateness, last_pose_ -> t.rec
  if (t.zero == 0) run_model_and_chain(t);  // pose -> model tick -> force chain -> t.force
  if (t.zero == 0) write_device(t);   // t.force -> device; t.rec's force and contacts, or a fault
  if (t.zero != 0) zero_on_fault(t);  // zero bits -> zero force, state reset, t.rec.fault
  remember(t);                        // contacts, engagement gain -> last_contacts_, stats
  publish(t);                         // t.rec + contacts -> net ring (+ signal), record ring
  account(begin);                     // ticks_, compute time -> tick_ns_sum_, tick_ns_max_
}

void HapticLoop::swap_in_pending_model() noexcept {
  if (retired_.load(std::memory_order_acquire) != nullptr) return;  // the last one not freed
  if (Bundle* fresh = pending_.exchange(nullptr, std::memory_order_acq_rel)) {
    retired_.store(current_.release(), std::memory_order_release);
    current_.reset(fresh);
    reset_force_chain(chain_);  // a new tool or parameters: engage afresh
  }
}

// A recording starts from a clean state (as a replay does): contacts restart at its first tick.
void HapticLoop::apply_record_request() noexcept {
  const int request = record_request_.exchange(0, std::memory_order_acq_rel);
  if (request == 0) return;
  recording_on_ = request == 1;
  if (recording_on_) {
    reset(current_->state);
    reset_force_chain(chain_);
  }
}

void HapticLoop::count_lateness(std::int64_t late_ns) noexcept {
  jitter_[jitter_bucket(late_ns)].fetch_add(1, std::memory_order_relaxed);
  store_max(max_late_ns_, late_ns);
}

std::uint32_t HapticLoop::watchdog(std::int64_t late_ns) noexcept {
  const std::uint32_t bits =
      watchdog_bits(late_ns, static_cast<std::int64_t>(config_.watchdog_late_s * 1e9));
  if (bits != 0) device_.write(DeviceCommand{});  // force to zero before anything else
  return bits;
}

bool HapticLoop::read_device(Tick& t) noexcept {
  DeviceSample sample;
  const DeviceStatus status = device_.read(t.deadline_ns, sample);
  if (status == DeviceStatus::Finished) {
    device_.write(DeviceCommand{});
    finished_.store(true, std::memory_order_release);
    stop_.store(true, std::memory_order_release);
    return false;
  }
  t.zero |= read_bits(status, sample.forced_fault, have_pose_, t.deadline_ns - last_sample_ns_,
                      static_cast<std::int64_t>(config_.device_timeout_s * 1e9));
  if (status == DeviceStatus::Ok) {
    // device pose -> scene pose (registration; identity skipped)
    last_device_pose_ = sample.pose;
    last_pose_ = identity_ ? sample.pose : to_scene(registration_, sample.pose);
    have_pose_ = true;
    last_sample_ns_ = t.deadline_ns;
  } else if (status == DeviceStatus::Absent) {
    have_pose_ = false;  // after a replug, wait for a fresh pose
  }
  return true;
}

// A re-centre (requested by a controller) only out of contact, so the force cannot step.
void HapticLoop::recentre() noexcept {
  if (!may_recentre(recentre_request_.load(std::memory_order_relaxed), have_pose_, last_contacts_,
                    identity_))
    return;
  recentre_request_.store(false, std::memory_order_relaxed);
  registration_.home =
      recentred_home(registration_, config_.registration.home, last_device_pose_.position);
  last_pose_ = to_scene(registration_, last_device_pose_);
  home_[0].store(registration_.home.x, std::memory_order_relaxed);
  home_[1].store(registration_.home.y, std::memory_order_relaxed);
  home_[2].store(registration_.home.z, std::memory_order_relaxed);
  recentres_.fetch_add(1, std::memory_order_relaxed);
}

DeviceState HapticLoop::device_presence(std::uint32_t zero) noexcept {
  const DeviceState state = presence(zero, device_.state());
  const bool absent = (zero & kZeroDeviceAbsent) != 0;
  if (absent && !absent_) absent_events_.fetch_add(1, std::memory_order_relaxed);
  absent_ = absent;
  device_state_.store(static_cast<std::uint8_t>(state), std::memory_order_relaxed);
  return state;
}

void HapticLoop::begin_record(Tick& t) noexcept {
  t.rec.seq = seq_++;
  t.rec.t_ns = t.deadline_ns;
  t.rec.late_ns = t.late_ns;
  t.rec.pose = last_pose_;
}

// tool pose (the virtual coupling's tool, device frame) -> scene pose -> model tick -> scene force
// -> device frame -> force chain (device frame)
void HapticLoop::run_model_and_chain(Tick& t) noexcept {
  Bundle& bundle = *current_;
  Pose model_pose = last_pose_;
  if (config_.profile && chain_config_.coupling) {
    const Pose tool{force_chain_tool(chain_, chain_config_, last_device_pose_.position),
                    last_device_pose_.orientation};
    model_pose = identity_ ? tool : to_scene(registration_, tool);
  }
  bundle.state.pulse_bpm = pulse_bpm_.load(std::memory_order_relaxed);  // set_pulse_bpm
  tick(*bundle.model, bundle.state, model_pose, 1e-9 * static_cast<double>(t.deadline_ns));
  t.force = bundle.state.f_device, t.torque = bundle.state.tau_device;
  t.active = bundle.state.f_pulse;
  if (!identity_) {
    t.force = force_to_device(registration_, t.force);
    t.torque = torque_to_device(registration_, t.torque);
    t.active = force_to_device(registration_, t.active);
  }
  if (config_.profile) run_force_chain_stage(t);
}

// The force chain (safety/force_chain.hpp): limits, engagement, passivity, step bound, clamp; the
// pulse passed as the known active force the passivity observer counts as an input.
void HapticLoop::run_force_chain_stage(Tick& t) noexcept {
  const ForceChainOutput out = run_force_chain(
      chain_, chain_config_, with_declared(*config_.profile, device_.declared_limits()), t.force,
      t.torque,
      // N per scene mm -> N per device mm (a device mm moves the tool `scale` scene mm)
      current_->state.stiffness * (identity_ ? 1.0 : registration_.scale),
      last_device_pose_.position, dt_s_, t.active);
  t.force = out.force, t.torque = out.torque, t.safety = out.status;
  if (out.damping_N_s_per_mm > 0.0) {
    passivity_ticks_.fetch_add(1, std::memory_order_relaxed);
    passivity_dissipated_mJ_.store(
        passivity_dissipated_mJ_.load(std::memory_order_relaxed) + out.dissipated_mJ,
        std::memory_order_relaxed);  // one writer: the loop
  }
}

void HapticLoop::write_device(Tick& t) noexcept {
  const DeviceStatus written = device_.write(DeviceCommand{t.force, t.torque});
  if (written != DeviceStatus::Ok && written != DeviceStatus::NoData) {
    t.zero |= kFaultDeviceWrite;
    return;
  }
  const State& state = current_->state;
  t.rec.force = identity_ ? t.force : force_to_scene(registration_, t.force);
  t.rec.torque = identity_ ? t.torque : torque_to_scene(registration_, t.torque);
  t.rec.u = state.u;
  t.rec.n_contact = state.n_contact;
  t.rec.tick_status = state.status;
  t.rec.safety_status = t.safety;
  t.state = &state;
}

void HapticLoop::zero_on_fault(Tick& t) noexcept {
  device_.write(DeviceCommand{});  // zero first, then report
  reset(current_->state);
  reset_force_chain(chain_);  // and ramp back in after it
  chain_.position_prev = last_device_pose_.position;
  chain_.have_prev = have_pose_;
  t.rec.fault = t.zero;
  if (t.zero & kFaultMask) {
    faults_.fetch_add(1, std::memory_order_relaxed);
    last_fault_.store(t.zero & kFaultMask, std::memory_order_relaxed);
  }
}

void HapticLoop::remember(const Tick& t) noexcept {
  last_contacts_ = t.rec.n_contact;  // the next re-centre waits for no contact
  if (config_.engage)
    engage_gain_.store(t.zero != 0 ? 0.0 : chain_.engagement.gain, std::memory_order_relaxed);
}

void HapticLoop::publish(const Tick& t) noexcept {
  const auto points = static_cast<std::uint32_t>(current_->model->contact_count());
  if (Snapshot* s = net_ring_.claim()) {
    s->tick = t.rec;
    s->device_state = t.device_state;
    s->contact_points = points;
    s->contact_count = 0;
    if (const State* state = t.state) {
      const std::size_t n = std::min<std::size_t>(points, s->contacts.size());
      for (std::size_t i = 0; i < n; ++i) {
        ContactSnapshot& c = s->contacts[i];
        c.x = state->x[i];
        c.s = state->s[i];
        c.p = state->p[i];
        c.f = state->f[i];
        c.in_contact = state->in_contact[i];
      }
      s->contact_count = static_cast<std::uint32_t>(n);
    }
    publish_pulse(t, *s);
    s->buttons = device_.buttons();  // an atomic load (training marks: a rising edge)
    // The network thread is woken (an eventfd write, never blocking: wake_signal.hpp) only when
    // it waits and a client is due a frame, the ring is half full or the device came or went
    // (Stats at once); otherwise it drains the ring on its own timer. No system call on a tick
    // nobody waits for (issue 41).
    commit_and_notify(net_ring_, net_signal_, t.rec.t_ns, t.device_state != net_device_state_);
    net_device_state_ = t.device_state;
  }
  if (recording_on_) {
    if (Snapshot* r = record_ring_.claim()) {
      r->tick = t.rec;
      r->device_state = t.device_state;
      r->contact_points = points;
      r->contact_count = 0;
      record_ring_.commit();
    }
  }
}

// The structure layers' outputs: the pulse's clock always, the forces when they were written.
void HapticLoop::publish_pulse(const Tick& t, Snapshot& s) const noexcept {
  const State& state = current_->state;
  s.pulse_wave = static_cast<float>(state.pulse_wave);
  s.pulse_force_N = t.state ? static_cast<float>(norm(state.f_pulse)) : 0.0f;
  s.organ_force_N = t.state ? static_cast<float>(norm(state.f_organ)) : 0.0f;
  s.pulse_bpm = static_cast<float>(pulse_bpm_.load(std::memory_order_relaxed));
}

void HapticLoop::account(std::int64_t begin_ns) noexcept {
  ticks_.fetch_add(1, std::memory_order_release);
  const std::int64_t spent = monotonic_ns() - begin_ns;
  tick_ns_sum_.fetch_add(static_cast<std::uint64_t>(spent), std::memory_order_relaxed);
  store_max(tick_ns_max_, spent);
}

void HapticLoop::collect_retired() {
  delete retired_.exchange(nullptr, std::memory_order_acq_rel);
}

void HapticLoop::swap_model(std::shared_ptr<const Model> model) {
  if (!model) throw UsageError("haptic loop: no model");
  auto fresh = std::make_unique<Bundle>(Bundle{model, make_state(*model)});
  collect_retired();
  delete pending_.exchange(fresh.release(), std::memory_order_acq_rel);
  const std::lock_guard lock(model_mutex_);
  requested_ = std::move(model);
}

std::shared_ptr<const Model> HapticLoop::model() const {
  const std::lock_guard lock(model_mutex_);
  return requested_;
}

std::uint64_t HapticLoop::set_recording(bool on) {
  const std::uint64_t first = ticks_.load(std::memory_order_acquire);
  recording_.store(on, std::memory_order_relaxed);
  record_request_.store(on ? 1 : 2, std::memory_order_release);
  return first;
}

LoopStats HapticLoop::stats() const {
  LoopStats s;
  s.ticks = ticks_.load(std::memory_order_relaxed);
  s.overruns = overruns_.load(std::memory_order_relaxed);
  s.faults = faults_.load(std::memory_order_relaxed);
  s.last_fault = last_fault_.load(std::memory_order_relaxed);
  for (std::size_t b = 0; b < kJitterBuckets; ++b)
    s.jitter[b] = jitter_[b].load(std::memory_order_relaxed);
  s.max_late_ns = max_late_ns_.load(std::memory_order_relaxed);
  s.tick_ns_sum = tick_ns_sum_.load(std::memory_order_relaxed);
  s.tick_ns_max = tick_ns_max_.load(std::memory_order_relaxed);
  s.realtime = realtime_.load(std::memory_order_relaxed);
  s.paused = paused();
  s.recording = recording_.load(std::memory_order_relaxed);
  s.finished = finished();
  s.device_state = device_state();
  s.absent_events = absent_events_.load(std::memory_order_relaxed);
  s.recentres = recentres_.load(std::memory_order_relaxed);
  s.engage_gain = engage_gain_.load(std::memory_order_relaxed);
  s.passivity_ticks = passivity_ticks_.load(std::memory_order_relaxed);
  s.passivity_dissipated_mJ = passivity_dissipated_mJ_.load(std::memory_order_relaxed);
  s.net_published = net_ring_.published();
  s.net_dropped = net_ring_.dropped();
  s.record_published = record_ring_.published();
  s.record_dropped = record_ring_.dropped();
  s.wake = waker_.stats();
  const std::int64_t started = started_ns_.load(std::memory_order_relaxed);
  s.running_ns = started > 0 ? monotonic_ns() - started : 0;
  s.loop_cpu_ns = loop_cpu_ns_.load(std::memory_order_relaxed);
  s.loop_cpu_wall_ns = loop_cpu_wall_ns_.load(std::memory_order_relaxed);
  s.net_signals = net_signal_.writes();
  return s;
}

}  // namespace palp::rt
