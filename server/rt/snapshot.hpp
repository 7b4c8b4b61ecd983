// What the haptic loop publishes every tick, and the lock-free hand-offs that carry it out of the
// real-time thread without waiting:
//   SnapshotRing   single producer, single consumer, bounded: the loop claims a preallocated slot,
//                  fills it and commits; when the ring is full the snapshot is dropped (counted),
//                  never waited for. One ring feeds the network thread, one the recorder.
//   LatestBox<T>   a triple buffer: one writer, one reader, the reader always gets the newest
//                  complete value and neither side ever waits (the remote device's pose).
// Slots are allocated once at construction; nothing on the producer side allocates or locks.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "base/device_state.hpp"
#include "base/vec.hpp"
#include "model/force_model.hpp"

namespace palp::rt {

// What clients are told about the device (the values of palp.v1 DeviceState; a device reports
// Present, Absent or Fault, never Unknown).
using DeviceState = palp::DeviceState;
using palp::to_string;

// One contact point of a tick.
struct ContactSnapshot {
  Vec3d x{};  // position
  Vec3d s{};  // surface point
  Vec3d p{};  // proxy
  Vec3d f{};  // force (N)
  std::uint8_t in_contact = 0;
};

// The device-level outcome of one tick: everything the recording keeps.
struct TickRecord {
  std::uint64_t seq = 0;  // tick number, from 0
  std::int64_t t_ns = 0;  // CLOCK_MONOTONIC deadline of the tick
  Pose pose{};            // device pose read this tick
  Vec3d force{};          // N, as written to the device (after safety filters, zero on fault)
  Vec3d torque{};         // N·mm
  Vec3d u{};              // mm
  std::int32_t n_contact = 0;
  std::uint32_t tick_status = 0;    // TickStatus bits
  std::uint32_t safety_status = 0;  // SafetyStatus bits
  std::uint32_t fault = 0;          // LoopFault bits (loop/step_stages.hpp)
  std::int64_t late_ns = 0;         // how late the tick started after its deadline
  bool operator==(const TickRecord& o) const {
    return seq == o.seq && t_ns == o.t_ns && pose.position == o.pose.position &&
           pose.orientation == o.pose.orientation && force == o.force && torque == o.torque &&
           u == o.u && n_contact == o.n_contact && tick_status == o.tick_status &&
           safety_status == o.safety_status && fault == o.fault && late_ns == o.late_ns;
  }
};

struct Snapshot {
  TickRecord tick;
  DeviceState device_state = DeviceState::Present;  // alongside the record (not recorded)
  std::uint32_t contact_points = 0;                 // points of the tool this tick
  std::uint32_t contact_count = 0;                  // entries valid in `contacts` (<= its capacity)
  std::vector<ContactSnapshot> contacts;            // capacity fixed at construction
  // The structure layers (model/structure_layers.hpp) at this tick, alongside (not recorded):
  float pulse_wave = 0;     // State::pulse_wave, 0 (diastole) .. 1 (systole)
  float pulse_force_N = 0;  // |State::f_pulse| (0 when the force was not written)
  float organ_force_N = 0;  // |State::f_organ| (likewise)
  float pulse_bpm = 0;      // the heart rate the loop gave this tick (HapticLoop::set_pulse_bpm)
  // The device's buttons held at this tick (Device::buttons; not recorded): bit 0 is
  // kMarkButton.
  std::uint32_t buttons = 0;
};

// The button whose press (a rising edge between two snapshots) marks a training task's spot:
// a Falcon's grip PLUS button (0x01; its centre and forward buttons are the clutch and the
// re-centre), a usb-haptic device's button 0.
inline constexpr std::uint32_t kMarkButton = 0x1;

class SnapshotRing {
 public:
  // `slots` >= 2 (rounded up to a power of two); every slot holds up to `contact_capacity`
  // contacts.
  SnapshotRing(std::size_t slots, std::size_t contact_capacity)
      : mask_(round_up(slots) - 1), slots_(mask_ + 1) {
    for (Snapshot& s : slots_) s.contacts.resize(contact_capacity);
  }
  SnapshotRing(const SnapshotRing&) = delete;
  SnapshotRing& operator=(const SnapshotRing&) = delete;

  std::size_t contact_capacity() const { return slots_[0].contacts.size(); }
  std::size_t capacity() const { return slots_.size(); }

  // Producer: a free slot to fill, or nullptr when the ring is full (the drop is counted).
  Snapshot* claim() noexcept {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_.load(std::memory_order_acquire) >= slots_.size()) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return nullptr;
    }
    return &slots_[head & mask_];
  }
  // Producer: publishes the slot returned by the last claim().
  void commit() noexcept {
    head_.store(head_.load(std::memory_order_relaxed) + 1, std::memory_order_release);
    published_.fetch_add(1, std::memory_order_relaxed);
  }

  // Consumer: the oldest unread snapshot, or nullptr.
  const Snapshot* front() const noexcept {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return nullptr;
    return &slots_[tail & mask_];
  }
  // Consumer: releases the snapshot returned by front().
  void pop() noexcept {
    tail_.store(tail_.load(std::memory_order_relaxed) + 1, std::memory_order_release);
  }

  // Snapshots committed and not yet popped (either side; a moment's view).
  std::size_t size() const noexcept {
    return static_cast<std::size_t>(head_.load(std::memory_order_relaxed) -
                                    tail_.load(std::memory_order_relaxed));
  }
  std::uint64_t published() const { return published_.load(std::memory_order_relaxed); }
  std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  static std::size_t round_up(std::size_t n) {
    std::size_t p = 2;
    while (p < n) p <<= 1;
    return p;
  }
  const std::size_t mask_;
  std::vector<Snapshot> slots_;
  alignas(64) std::atomic<std::uint64_t> head_{0};
  alignas(64) std::atomic<std::uint64_t> tail_{0};
  alignas(64) std::atomic<std::uint64_t> published_{0};
  std::atomic<std::uint64_t> dropped_{0};
};

// Triple buffer: write() never waits, read() returns the newest complete value.
template <class T>
class LatestBox {
 public:
  LatestBox() = default;
  LatestBox(const LatestBox&) = delete;
  LatestBox& operator=(const LatestBox&) = delete;

  // Writer side.
  void write(const T& value) noexcept {
    buffers_[back_] = value;
    const unsigned old = middle_.exchange(back_ | kFresh, std::memory_order_acq_rel);
    back_ = old & kIndex;
  }
  // Reader side: true and the newest value when one was written since the last read.
  bool read(T& out) noexcept {
    if (!(middle_.load(std::memory_order_relaxed) & kFresh)) return false;
    const unsigned old = middle_.exchange(front_, std::memory_order_acq_rel);
    front_ = old & kIndex;
    out = buffers_[front_];
    return true;
  }

 private:
  static constexpr unsigned kFresh = 4, kIndex = 3;
  T buffers_[3]{};
  unsigned back_ = 0;                // writer's
  unsigned front_ = 1;               // reader's
  std::atomic<unsigned> middle_{2};  // shared: index | kFresh
};

}  // namespace palp::rt
