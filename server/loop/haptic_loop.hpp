// The real-time haptic loop: a dedicated thread ticking at a fixed rate on absolute deadlines.
//
// Every tick (step()):
//   watchdog (deadline) -> read device -> tick (force model) -> safety filters (device profile)
//   -> write device -> publish a snapshot (network ring) and a record (record ring, when on)
// and never allocates, locks, logs, serializes or throws. Deadlines are absolute (CLOCK_MONOTONIC):
// tick n is due at start + n * period; how the loop waits for one (sleep, or sleep then a bounded
// spin) and the skipping of deadlines a long tick passed (counted as overruns) are in wake.hpp.
// The lateness of every tick's start goes into a fixed histogram, the wake-up latency of every
// sleep into another. After a snapshot it publishes, the loop wakes the network thread
// (net_signal(), an eventfd written without blocking; rt/wake_signal.hpp) only when that thread
// waits and a client is due a frame (or the ring is half full, or the device came or went): no
// system call on the loop thread but its sleep while nobody is due a frame.
//
// Watchdog: a tick that starts more than `watchdog_late_s` after its deadline, or a device that
// answers Timeout / Disconnected / Error (or NoData for longer than `device_timeout_s`), zeroes
// the force first - the device is written zero before anything else happens - and then the
// fault is reported: counted, its bits kept in LoopStats::last_fault and in the tick's snapshot.
// The model state is reset (proxies forgotten), so contact restarts cleanly when the fault
// clears; with a device profile engagement then ramps the force back in.
//
// Zeroed ticks that are not faults (paused, no pose yet, device absent) carry their own bits too,
// so a replay reproduces them (DeviceSample::forced_fault).
//
// Hot-plug: a device answering Absent is not a fault. The force is zeroed that very tick, the
// model state resets, the loop keeps ticking, and every snapshot carries the device's state
// (Device::state(): Present / Absent / Fault). Each unplug counts once (LoopStats::absent_events);
// after a replug the loop waits for the first pose again (kZeroNoPose), so the NoData timeout does
// not fire on the stale pose from before.
//
// Parameters change without the loop allocating: the new Model and its State are built by the
// caller and handed over through an atomic pointer; the loop swaps them in at the start of a
// tick and hands the old one back to be freed outside the loop.
//
// With a device profile the model is evaluated at the virtual coupling's tool, not at the device
// (safety/force_chain.hpp); the published pose stays the device's, the contacts the model's.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "devices/device.hpp"
#include "loop/step_stages.hpp"
#include "loop/wake.hpp"
#include "model/force_model.hpp"
#include "model/registration.hpp"
#include "rt/snapshot.hpp"
#include "rt/wake_signal.hpp"
#include "safety/engagement.hpp"
#include "safety/force_chain.hpp"
#include "safety/safety.hpp"

namespace palp::rt {

// The arteries' heart rate a loop takes (bpm; 0 = no pulse), as ForceParams::pulse_bpm's range.
inline constexpr double kMaxPulseBpm = 240.0;
// "" when `bpm` is a rate the loop takes, else why not (for a UsageError or a CommandResult).
std::string pulse_bpm_refusal(double bpm);

struct LoopConfig {
  double rate_hz = 1000.0;
  bool realtime = true;            // try SCHED_FIFO and mlockall; a warning when not permitted
  int priority = 80;               // SCHED_FIFO priority
  double watchdog_late_s = 0.005;  // a tick starting later than this: fault (0 = off)
  double device_timeout_s = 0.1;   // device NoData for longer than this: fault (0 = off)
  const DeviceProfile* profile = nullptr;  // safety filters after the model (nullptr: none)
  // Force engagement (safety/engagement.hpp) after start and every reset; unset: none (offline
  // runs, tests of the raw model). palpd sets it whenever limits apply.
  std::optional<EngageParams> engage;
  // The passivity observer/controller (safety/passivity.hpp) at the device port, damping up to
  // the profile's damping; needs a profile. palpd sets it whenever limits apply.
  bool passivity = false;
  // The virtual coupling (safety/virtual_coupling.hpp) between the model and the device: the
  // model is evaluated at the coupling's tool, the device gets the coupling's spring-damper (at
  // most the profile's stiffness). Needs a profile; false: the stiffness limiter instead.
  bool coupling = true;
  // Device frame -> scene (model/registration.hpp): applied to every pose read and, transposed,
  // to every force written; the safety filters run in the device frame. Identity: skipped.
  Registration registration;
  std::size_t net_slots = 1024;      // snapshot ring toward the network
  std::size_t record_slots = 16384;  // record ring toward the recorder
  std::size_t contact_capacity = 0;  // contacts per snapshot; 0 = the tool's, at least 64
  WakeConfig wake;  // how the loop waits for deadlines (wake.hpp); hybrid: timer slack 1 ns
  int cpu = -1;     // >= 0: the loop thread is pinned to this CPU
};

struct LoopStats {
  std::uint64_t ticks = 0;
  std::uint64_t overruns = 0;  // deadlines skipped because a tick ended past the next one
  std::uint64_t faults = 0;    // ticks zeroed by the watchdog
  std::uint32_t last_fault = 0;
  std::array<std::uint64_t, kJitterBuckets> jitter{};  // wake-up lateness histogram
  std::int64_t max_late_ns = 0;
  std::uint64_t tick_ns_sum = 0;  // compute time of the ticks (step() only)
  std::int64_t tick_ns_max = 0;
  bool realtime = false;  // SCHED_FIFO and locked memory both in effect
  bool paused = false;
  bool recording = false;
  bool finished = false;  // the device reported Finished and the loop stopped
  DeviceState device_state = DeviceState::Present;  // as of the last tick
  std::uint64_t absent_events = 0;                  // present -> absent transitions (unplugs)
  std::uint64_t recentres = 0;                      // re-centres done (request_recentre)
  double engage_gain = 1.0;                         // as of the last tick (1: no engagement)
  std::uint64_t passivity_ticks = 0;                // ticks the passivity controller damped
  double passivity_dissipated_mJ = 0.0;             // energy it took out, in all
  std::uint64_t net_published = 0, net_dropped = 0;
  std::uint64_t record_published = 0, record_dropped = 0;
  WakeStats wake;                     // wake-up latency histogram, spin window and time spun
  std::int64_t running_ns = 0;        // since the thread's first tick (0: not started)
  std::int64_t loop_cpu_ns = 0;       // CPU time of the loop thread (sampled every 256 ticks)
  std::int64_t loop_cpu_wall_ns = 0;  // the time running that loop_cpu_ns covers
  std::uint64_t net_signals = 0;      // eventfd writes toward the network thread
};

class HapticLoop {
 public:
  // `device` must be configured and activated by the caller and outlive the loop. UsageError
  // for a rate outside [1, 100000] Hz.
  HapticLoop(std::shared_ptr<const Model> model, Device& device, LoopConfig config);
  ~HapticLoop();  // stop()
  HapticLoop(const HapticLoop&) = delete;
  HapticLoop& operator=(const HapticLoop&) = delete;

  // Starts the thread (ResourceError if it cannot). The real-time setup's outcome (scheduling,
  // memory, CPU pinning, the wake-up mode and its calibrated spin window) is in
  // realtime_report() once start() returns.
  void start();
  // Stops and joins the thread, then writes zero force to the device. Idempotent.
  void stop();
  bool running() const { return thread_.joinable() && !finished_.load(); }
  bool finished() const { return finished_.load(std::memory_order_acquire); }
  const std::string& realtime_report() const { return realtime_report_; }

  // One tick without the thread (tests, offline replays): deadline and actual start time.
  void step(std::int64_t deadline_ns, std::int64_t now_ns) noexcept;

  // Not real time: the next tick runs `model` (tool or parameters changed). The loop's state
  // restarts (no contacts). The previous model is freed here or at the next call.
  void swap_model(std::shared_ptr<const Model> model);
  std::shared_ptr<const Model> model() const;

  void set_paused(bool paused) { paused_.store(paused, std::memory_order_relaxed); }
  // Not real time: the arteries' heart rate from the next tick on (State::pulse_bpm, set by the
  // loop before every tick from this atomic; the contacts and the pulse's phase are kept). Starts
  // at the first model's ForceParams::pulse_bpm; a swapped-in model does not change it.
  // UsageError for a rate pulse_bpm_refusal refuses.
  void set_pulse_bpm(double bpm);
  double pulse_bpm() const { return pulse_bpm_.load(std::memory_order_relaxed); }
  bool paused() const { return paused_.load(std::memory_order_relaxed); }
  // From the next tick on, records go to record_ring() (or stop going there); a recording starts
  // with the model state reset, so a replay from a fresh state reproduces it. Returns a seq no
  // later than the first recorded tick (older ring leftovers have smaller seqs).
  std::uint64_t set_recording(bool on);

  SnapshotRing& net_ring() { return net_ring_; }
  WakeSignal& net_signal() { return net_signal_; }
  SnapshotRing& record_ring() { return record_ring_; }
  LoopStats stats() const;
  // Not real time: at the next tick out of contact, move the registration's home so that where
  // the device is now maps to the configured home point (a re-centre, like lifting a mouse).
  // Ignored while in contact (it would step the force); count in LoopStats::recentres.
  void request_recentre() { recentre_request_.store(true, std::memory_order_relaxed); }
  // The registration's home now (scene mm).
  Vec3d registration_home() const;
  const LoopConfig& config() const { return config_; }
  std::int64_t period_ns() const { return period_ns_; }
  const Device& device() const { return device_; }
  DeviceState device_state() const {
    return static_cast<DeviceState>(device_state_.load(std::memory_order_relaxed));
  }

 private:
  struct Bundle {
    std::shared_ptr<const Model> model;
    State state;
  };
  void run();
  void sample_cpu(std::int64_t cpu0) noexcept;  // the loop thread's CPU time since cpu0
  std::string realtime_setup();  // pinning and scheduling of the started thread; its report
  void collect_retired();

  // The stages of step(), in order (haptic_loop.cpp; the pure ones in step_stages.hpp).
  struct Tick;  // one tick's values, handed from stage to stage
  void swap_in_pending_model() noexcept;
  void apply_record_request() noexcept;
  void count_lateness(std::int64_t late_ns) noexcept;
  std::uint32_t watchdog(std::int64_t late_ns) noexcept;
  bool read_device(Tick& t) noexcept;
  void recentre() noexcept;
  DeviceState device_presence(std::uint32_t zero) noexcept;
  void begin_record(Tick& t) noexcept;
  void run_model_and_chain(Tick& t) noexcept;
  void run_force_chain_stage(Tick& t) noexcept;
  void write_device(Tick& t) noexcept;
  void zero_on_fault(Tick& t) noexcept;
  void remember(const Tick& t) noexcept;
  void publish(const Tick& t) noexcept;
  void publish_pulse(const Tick& t, Snapshot& s) const noexcept;
  void account(std::int64_t begin_ns) noexcept;

  LoopConfig config_;
  Device& device_;
  std::int64_t period_ns_;
  double dt_s_;

  // Real-time side.
  std::unique_ptr<Bundle> current_;
  std::atomic<Bundle*> pending_{nullptr};
  std::atomic<Bundle*> retired_{nullptr};
  std::uint64_t seq_ = 0;
  Pose last_pose_{};         // scene frame
  Pose last_device_pose_{};  // device frame (as read)
  ForceChainConfig chain_config_;
  ForceChainState chain_;
  Registration registration_;  // loop side: config_.registration, home moved by re-centres
  bool identity_ = true;
  bool have_pose_ = false;
  std::int32_t last_contacts_ = 0;
  std::int64_t last_sample_ns_ = 0;
  bool absent_ = false;                                  // the last tick found the device absent
  DeviceState net_device_state_ = DeviceState::Present;  // in the last snapshot to the network

  // Shared counters (relaxed atomics: written by the loop, read by anyone).
  std::atomic<std::uint64_t> ticks_{0}, overruns_{0}, faults_{0};
  std::atomic<std::uint32_t> last_fault_{0};
  std::array<std::atomic<std::uint64_t>, kJitterBuckets> jitter_{};
  std::atomic<std::int64_t> max_late_ns_{0}, tick_ns_max_{0};
  std::atomic<std::uint64_t> tick_ns_sum_{0};
  std::atomic<std::uint64_t> absent_events_{0}, recentres_{0};
  std::atomic<bool> recentre_request_{false};
  std::atomic<double> engage_gain_{1.0};
  std::atomic<std::uint64_t> passivity_ticks_{0};
  std::atomic<double> passivity_dissipated_mJ_{0.0};
  std::array<std::atomic<double>, 3> home_{};
  std::atomic<std::uint8_t> device_state_{static_cast<std::uint8_t>(DeviceState::Present)};
  std::atomic<bool> paused_{false}, recording_{false}, stop_{false}, finished_{false};
  std::atomic<double> pulse_bpm_{0.0};  // set_pulse_bpm -> State::pulse_bpm every tick
  std::atomic<int> record_request_{0};  // 1: start recording (reset state), 2: stop
  bool recording_on_ = false;           // loop side
  // set by start() while the DDS and network threads may already read stats()
  std::atomic<bool> realtime_{false};

  SnapshotRing net_ring_;
  SnapshotRing record_ring_;
  WakeSignal net_signal_;
  Waker waker_;
  std::atomic<int> setup_{0};  // 1: start() set the thread up; 2: the thread calibrated
  std::atomic<std::int64_t> started_ns_{0}, loop_cpu_ns_{0}, loop_cpu_wall_ns_{0};

  mutable std::mutex model_mutex_;  // guards requested_ (never taken by the loop)
  std::shared_ptr<const Model> requested_;
  std::string realtime_report_;
  std::string slack_report_;  // written by the thread before it calibrates
  std::thread thread_;
};

}  // namespace palp::rt
