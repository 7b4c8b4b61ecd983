// The emulated Falcon: see falcon_emulator.hpp. Wire constants in nif:: (cited there); the
// mechanism through falcon_reference.hpp (libnifalcon's Stamper kinematics, metres).
#include "support/falcon_emulator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace palp::usbemu {

namespace ref = falconref;

namespace {

DeviceSpec falcon_spec() {
  DeviceSpec s;
  s.vendor_id = nif::kVendorId;
  s.product_id = nif::kProductId;
  s.bcd_device = 0x0400;
  s.bcd_usb = 0x0200;
  InterfaceSpec& itf = s.interfaces[0];
  itf.interface_class = 0xff;
  itf.subclass = 0xff;
  itf.protocol = 0xff;
  itf.endpoints = {{nif::kBulkIn, 0x02, 64, 0}, {nif::kBulkOut, 0x02, 64, 0}};
  return s;
}

constexpr double kMassKg = 0.15;     // the handle and arms, moving mass (emulation choice)
constexpr double kFriction = 0.002;  // N s/mm, the mechanism's own damping (emulation choice)
constexpr double kIndexZ = 150.0;    // mm: pulling out past here crosses the encoder index
// FTDI modem and line status as an FT232 reports them idle (emulation choice; the host skips them)
constexpr std::uint8_t kModemStatus[nif::kModemStatusBytes] = {0x31, 0x60};

ref::V3 metres(const Vec3d& p_mm) {
  return {p_mm.x * 1e-3, p_mm.y * 1e-3, p_mm.z * 1e-3};
}

// One 16-bit value from four bytes, each 0x41 + a nibble, least significant first (SDK:51-55);
// false when a byte is out of that range.
bool get_nibbles(const std::uint8_t* in, std::uint16_t& value) {
  value = 0;
  for (int n = 0; n < 4; ++n) {
    if (in[n] < nif::kNibbleOffset || in[n] > nif::kNibbleOffset + 0x0f) return false;
    value = std::uint16_t(value | ((in[n] - nif::kNibbleOffset) << (4 * n)));
  }
  return true;
}
void put_nibbles(std::uint16_t value, std::uint8_t* out) {
  for (int n = 0; n < 4; ++n)
    out[n] = std::uint8_t(nif::kNibbleOffset + ((value >> (4 * n)) & 0x0f));  // SDK:87-90, 96
}

// A host frame (SDK formatInput, SDK:74-98, read back): three signed efforts and byte 13.
bool decode_host(const std::uint8_t* in, std::array<std::int16_t, 3>& efforts,
                 std::uint8_t& control) {
  if (in[0] != nif::kFrameOpen || in[nif::kFrameBytes - 1] != nif::kFrameClose) return false;
  for (int i = 0; i < 3; ++i) {
    std::uint16_t v = 0;
    if (!get_nibbles(in + 1 + 4 * i, v)) return false;
    efforts[std::size_t(i)] = static_cast<std::int16_t>(v);
  }
  for (const int at : {13, 14})
    if (in[at] < nif::kNibbleOffset || in[at] > nif::kNibbleOffset + 0x0f) return false;
  control = std::uint8_t(in[13] - nif::kNibbleOffset);
  return true;
}

// A device frame as SDK formatOutput (SDK:40-72) reads it: encoders, then byte 13 = 0x41 +
// (homing status << 4 | grip nibble), byte 14 0x41.
void encode_device(const std::array<std::int16_t, 3>& encoders, std::uint8_t grip,
                   std::uint8_t homed, std::uint8_t out[nif::kFrameBytes]) {
  out[0] = nif::kFrameOpen;
  for (int i = 0; i < 3; ++i)
    put_nibbles(static_cast<std::uint16_t>(encoders[std::size_t(i)]), out + 1 + 4 * i);
  out[13] = std::uint8_t(nif::kNibbleOffset + ((homed & nif::kAllHomed) << 4) + (grip & 0x0f));
  out[14] = nif::kNibbleOffset;
  out[15] = nif::kFrameClose;
}

bool ends_with_probe(const std::vector<std::uint8_t>& rx) {
  return rx.size() >= nif::kBootProbe.size() &&
         std::equal(nif::kBootProbe.begin(), nif::kBootProbe.end(),
                    rx.end() - std::ptrdiff_t(nif::kBootProbe.size()));
}

}  // namespace

EmulatedFalcon::EmulatedFalcon(UsbTestbed& testbed, std::vector<std::uint8_t> firmware)
    : firmware_(std::move(firmware)), usb_(testbed, falcon_spec()) {
  usb_.on_control([this](const ControlRequest& r) { return control(r); });
  usb_.on_out([this](std::uint8_t endpoint, const std::vector<std::uint8_t>& packet) {
    if (endpoint == nif::kBulkOut) out(packet);
  });
}

EmulatedFalcon::~EmulatedFalcon() {
  usb_.stop_in_stream();
}

void EmulatedFalcon::reset_power() {
  mode_ = Mode::Boot;
  baud_ = 0;
  latency_ = 16;
  dtr_ = dtr_reset_ = false;
  tx_.clear();
  boot_rx_.clear();
  host_rx_.clear();
  image_.clear();
  efforts_ = {};
  control_ = 0;
  homed_ = 0;
  // relative encoders: an unknown count at power-on until the index is crossed
  offsets_ = {137.0, -211.0, 389.0};
  last_tick_ns_ = -1;
  last_in_ns_ = 0;  // the new stream's device time starts at 0 again
}

void EmulatedFalcon::power_on() {
  {
    const std::lock_guard lock(mutex_);
    reset_power();
  }
  usb_.plug();
  usb_.start_in_stream(
      // a bridge keeps what its serial side received until the host reads it: nothing is
      // dropped (a busy host, e.g. a loaded CI machine, reads late but loses no frame)
      nif::kBulkIn, 1000.0, [this](std::uint64_t, std::int64_t t_ns) { return tick(t_ns); }, 4096);
}

void EmulatedFalcon::unplug() {
  usb_.stop_in_stream();
  usb_.unplug();
  const std::lock_guard lock(mutex_);
  reset_power();
}

void EmulatedFalcon::hold(const Vec3d& target, double k, double c) {
  const std::lock_guard lock(mutex_);
  hand_ = true;
  target_ = target;
  k_ = k;
  c_ = c;
}
void EmulatedFalcon::release_hand() {
  const std::lock_guard lock(mutex_);
  hand_ = false;
}
void EmulatedFalcon::set_buttons(std::uint8_t buttons) {
  const std::lock_guard lock(mutex_);
  buttons_ = buttons & 0x0f;
}
void EmulatedFalcon::corrupt_replies(int n) {
  const std::lock_guard lock(mutex_);
  corrupt_ = n;
}
void EmulatedFalcon::cut_replies(int n) {
  const std::lock_guard lock(mutex_);
  cut_ = n;
}
void EmulatedFalcon::drop_replies(int n) {
  const std::lock_guard lock(mutex_);
  drop_ = n;
}
void EmulatedFalcon::inject(std::vector<std::uint8_t> bytes) {
  const std::lock_guard lock(mutex_);
  inject_ = std::move(bytes);
}
void EmulatedFalcon::corrupt_echo_attempts(int n) {
  const std::lock_guard lock(mutex_);
  echo_faults_ = n;
}
void EmulatedFalcon::delay_first_probe_reply() {
  const std::lock_guard lock(mutex_);
  delay_probe_reply_ = true;
}
void EmulatedFalcon::set_running() {
  const std::lock_guard lock(mutex_);
  mode_ = Mode::Running;
}

EmulatedFalcon::Snapshot EmulatedFalcon::snapshot() {
  const std::lock_guard lock(mutex_);
  Snapshot s = counters_;
  s.running = mode_ == Mode::Running;
  s.homed = homed_;
  s.position = p_;
  s.motor_force = motor_force_;
  s.hand_force = hand_force_;
  s.efforts = efforts_;
  s.control = control_;
  return s;
}

ControlReply EmulatedFalcon::control(const ControlRequest& r) {
  const std::lock_guard lock(mutex_);
  if (probe_reply_pending_) {  // a probe's answer that comes after the one before it was read
    tx_.insert(tx_.end(), nif::kBootReply.begin(), nif::kBootReply.end());
    probe_reply_pending_ = false;
  }
  if (r.request_type != nif::kVendorOut) return ControlReply::stalled();
  switch (r.request) {
    case nif::kSioReset:
      if (r.value == nif::kPurgeRx) {  // what the chip holds for the host
        tx_.clear();
        usb_.clear_in(nif::kBulkIn);
      }
      break;
    case nif::kSioModemCtrl:
      if (r.value == nif::kDtrHigh) {
        if (!dtr_) {  // DTR low -> high resets the DSP into its bootloader
          mode_ = Mode::Boot;
          dtr_reset_ = true;
          boot_rx_.clear();
          homed_ = 0;
          efforts_ = {};
          ++counters_.dtr_resets;
        }
        dtr_ = true;
      } else if (r.value == nif::kDtrLow) {
        dtr_ = false;
      }
      break;
    case nif::kSioSetBaudRate:
      baud_ = r.value;
      if (baud_ == nif::kBaudRuntime && mode_ == Mode::Loading) {
        const bool good = image_ == firmware_;
        mode_ = good ? Mode::Running : Mode::Crashed;
        if (good) ++counters_.loads;
      }
      break;
    case nif::kSioSetLatency:
      latency_ = std::max<std::uint16_t>(1, r.value);
      break;
    case nif::kSioSetData:
    case nif::kSioSetFlowCtrl:
      break;
    default:
      return ControlReply::stalled();
  }
  return ControlReply::ack();
}

void EmulatedFalcon::boot_out(const std::vector<std::uint8_t>& packet) {
  switch (mode_) {
    case Mode::Boot:
      if (!dtr_reset_ || baud_ != nif::kBaud9600) return;
      boot_rx_.insert(boot_rx_.end(), packet.begin(), packet.end());
      if (ends_with_probe(boot_rx_)) {
        probe_reply_held_ = delay_probe_reply_;
        delay_probe_reply_ = false;
        if (!probe_reply_held_)
          tx_.insert(tx_.end(), nif::kBootReply.begin(), nif::kBootReply.end());
        boot_rx_.clear();
        mode_ = Mode::Probed;
        ++counters_.probes;
      }
      return;
    case Mode::Probed:
      if (baud_ == nif::kBaud9600) {  // the probe again: answered again
        boot_rx_.insert(boot_rx_.end(), packet.begin(), packet.end());
        if (ends_with_probe(boot_rx_)) {
          // the held answer now; this probe's own once the host has taken it (at its next
          // control request)
          tx_.insert(tx_.end(), nif::kBootReply.begin(), nif::kBootReply.end());
          probe_reply_pending_ = probe_reply_held_;
          probe_reply_held_ = false;
          boot_rx_.clear();
        }
        return;
      }
      if (baud_ == nif::kBaudUpload && !dtr_ && packet.size() == 1 &&
          packet[0] == nif::kBootEnter) {
        tx_.push_back(nif::kBootEnter);
        mode_ = Mode::Loading;
        image_.clear();
        echo_fault_this_load_ = echo_faults_ > 0;
        if (echo_faults_ > 0) --echo_faults_;
      }
      return;
    case Mode::Loading:
      if (baud_ != nif::kBaudUpload) return;
      for (const std::uint8_t b : packet) {
        image_.push_back(b);
        const bool flip = echo_fault_this_load_ && image_.size() == 100;
        tx_.push_back(flip ? std::uint8_t(b ^ 0x01) : b);
        ++counters_.echoed;
      }
      return;
    case Mode::Crashed:
    case Mode::Running:
      return;
  }
}

void EmulatedFalcon::out(const std::vector<std::uint8_t>& packet) {
  const std::lock_guard lock(mutex_);
  if (mode_ != Mode::Running) {
    boot_out(packet);
    return;
  }
  if (baud_ != nif::kBaudRuntime) return;
  host_rx_.insert(host_rx_.end(), packet.begin(), packet.end());
  take_host_frames();
}

void EmulatedFalcon::take_host_frames() {
  while (host_rx_.size() >= nif::kFrameBytes) {
    const auto start = std::find(host_rx_.begin(), host_rx_.end(), nif::kFrameOpen);
    host_rx_.erase(host_rx_.begin(), start);
    if (host_rx_.size() < nif::kFrameBytes) break;
    std::array<std::int16_t, 3> efforts{};
    std::uint8_t control = 0;
    if (!decode_host(host_rx_.data(), efforts, control)) {
      ++counters_.bad_frames;
      host_rx_.erase(host_rx_.begin());
      continue;
    }
    host_rx_.erase(host_rx_.begin(), host_rx_.begin() + std::ptrdiff_t(nif::kFrameBytes));
    ++counters_.frames_in;
    if ((homed_ & nif::kAllHomed) != nif::kAllHomed && (efforts[0] || efforts[1] || efforts[2]))
      ++counters_.nonzero_while_unhomed;
    for (const std::int16_t e : efforts)
      if (std::abs(int(e)) > ref::kDocumentedEffortCap) {
        ++counters_.over_cap;
        break;
      }
    efforts_ = efforts;
    control_ = control;
    reply();
  }
}

void EmulatedFalcon::reply() {
  if (drop_ > 0) {
    --drop_;
    return;
  }
  tx_.insert(tx_.end(), inject_.begin(), inject_.end());
  inject_.clear();
  std::array<std::int16_t, 3> encoders{};
  ref::Angles q;
  if (ref::ik(metres(p_), q))
    for (std::size_t i = 0; i < 3; ++i) {
      // KIN:61 inverted, theta1 in degrees as STA:307 converts it
      const double counts = ref::encoder_for_theta_deg(q.theta1[i] / ref::kDegToRad);
      encoders[i] = static_cast<std::int16_t>(std::lround(counts + offsets_[i]));
    }
  std::uint8_t bytes[nif::kFrameBytes];
  encode_device(encoders, buttons_, homed_, bytes);
  std::size_t size = nif::kFrameBytes;
  if (corrupt_ > 0) {
    --corrupt_;
    bytes[5] = 0x20;  // out of the nibble range
  } else if (cut_ > 0) {
    --cut_;
    size = 9;  // the rest never arrives
  }
  tx_.insert(tx_.end(), bytes, bytes + size);
  ++counters_.replies;
}

// Homing: with the homing bit set, a leg pulled past its index angle gets its true count.
void EmulatedFalcon::home_legs() {
  ref::Angles now, index;
  if (!(control_ & nif::kHomingBit) || !ref::ik(metres(p_), now) ||
      !ref::ik(metres({0, 0, kIndexZ}), index))
    return;
  for (std::size_t i = 0; i < 3; ++i)
    if (now.theta1[i] >= index.theta1[i]) {
      homed_ = std::uint8_t(homed_ | (1u << i));
      offsets_[i] = 0.0;
    }
}

void EmulatedFalcon::step(double dt) {
  home_legs();
  const int substeps = 8;
  const double h = dt / substeps;
  const ref::V3 effort{double(efforts_[0]), double(efforts_[1]), double(efforts_[2])};
  for (int s = 0; s < substeps; ++s) {
    ref::V3 f{};
    if (!ref::force_from_efforts(metres(p_), effort, f)) f = {};
    const Vec3d motor{f[0], f[1], f[2]};
    const Vec3d hand = hand_ ? (target_ - p_) * k_ - v_ * c_ : Vec3d{};
    const Vec3d total = motor + hand - v_ * kFriction;
    motor_force_ = motor;
    hand_force_ = hand;
    v_ += total * (1000.0 / kMassKg * h);  // N / kg = m/s^2 = 1000 mm/s^2
    const Vec3d next = p_ + v_ * h;
    ref::Angles q;
    if (std::abs(next.x) < 60 && std::abs(next.y) < 60 && next.z > 60 && next.z < 170 &&
        ref::ik(metres(next), q))
      p_ = next;
    else
      v_ = {};  // a mechanical stop
  }
}

std::optional<std::vector<std::uint8_t>> EmulatedFalcon::tick(std::int64_t t_ns) {
  const std::lock_guard lock(mutex_);
  if (last_tick_ns_ >= 0) step(std::min(double(t_ns - last_tick_ns_) * 1e-9, 0.005));
  last_tick_ns_ = t_ns;
  if (tx_.empty() && t_ns - last_in_ns_ < std::int64_t(latency_) * 1'000'000) return std::nullopt;
  last_in_ns_ = t_ns;
  std::vector<std::uint8_t> packet(std::begin(kModemStatus), std::end(kModemStatus));
  const std::size_t n = std::min<std::size_t>(tx_.size(), nif::kUsbPacket - packet.size());
  packet.insert(packet.end(), tx_.begin(), tx_.begin() + static_cast<std::ptrdiff_t>(n));
  tx_.erase(tx_.begin(), tx_.begin() + static_cast<std::ptrdiff_t>(n));
  return packet;
}

}  // namespace palp::usbemu
