// The emulated Falcon: see falcon_emulator.hpp.
#include "support/falcon_emulator.hpp"

#include <algorithm>
#include <cmath>

#include "model/falcon_kinematics.hpp"

namespace palp::usbemu {

namespace fp = usb::falcon;
namespace fk = falcon;

namespace {

DeviceSpec falcon_spec() {
  DeviceSpec s;
  s.vendor_id = fp::kVendor;
  s.product_id = fp::kProduct;
  s.bcd_device = 0x0400;
  s.bcd_usb = 0x0200;
  InterfaceSpec& itf = s.interfaces[0];
  itf.interface_class = 0xff;
  itf.subclass = 0xff;
  itf.protocol = 0xff;
  itf.endpoints = {{fp::kEndpointIn, 0x02, 64, 0}, {fp::kEndpointOut, 0x02, 64, 0}};
  return s;
}

constexpr double kMassKg = 0.15;     // the handle and arms, moving mass (emulation choice)
constexpr double kFriction = 0.002;  // N s/mm, the mechanism's own damping (emulation choice)
constexpr double kIndexZ = 150.0;    // mm: pulling out past here crosses the encoder index

}  // namespace

EmulatedFalcon::EmulatedFalcon(UsbTestbed& testbed, std::vector<std::uint8_t> firmware)
    : firmware_(std::move(firmware)), usb_(testbed, falcon_spec()) {
  usb_.on_control([this](const ControlRequest& r) { return control(r); });
  usb_.on_out([this](std::uint8_t endpoint, const std::vector<std::uint8_t>& packet) {
    if (endpoint == fp::kEndpointOut) out(packet);
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
      fp::kEndpointIn, 1000.0, [this](std::uint64_t, std::int64_t t_ns) { return tick(t_ns); },
      4096);
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
  if (r.request_type != fp::kFtdiRequestType) return ControlReply::stalled();
  switch (r.request) {
    case fp::kSioReset:
      if (r.value == fp::kPurgeRx) {  // what the chip holds for the host
        tx_.clear();
        usb_.clear_in(fp::kEndpointIn);
      }
      break;
    case fp::kSioModemCtrl:
      if (r.value == fp::kDtrHigh) {
        if (!dtr_) {  // DTR low -> high resets the DSP into its bootloader
          mode_ = Mode::Boot;
          dtr_reset_ = true;
          boot_rx_.clear();
          homed_ = 0;
          efforts_ = {};
          ++counters_.dtr_resets;
        }
        dtr_ = true;
      } else if (r.value == fp::kDtrLow) {
        dtr_ = false;
      }
      break;
    case fp::kSioSetBaudRate:
      baud_ = r.value;
      if (baud_ == fp::kBaudRuntime && mode_ == Mode::Loading) {
        const bool good = image_ == firmware_;
        mode_ = good ? Mode::Running : Mode::Crashed;
        if (good) ++counters_.loads;
      }
      break;
    case fp::kSioSetLatency:
      latency_ = std::max<std::uint16_t>(1, r.value);
      break;
    case fp::kSioSetData:
    case fp::kSioSetFlowCtrl:
      break;
    default:
      return ControlReply::stalled();
  }
  return ControlReply::ack();
}

void EmulatedFalcon::out(const std::vector<std::uint8_t>& packet) {
  const std::lock_guard lock(mutex_);
  switch (mode_) {
    case Mode::Boot:
      if (!dtr_reset_ || baud_ != fp::kBaud9600) return;
      boot_rx_.insert(boot_rx_.end(), packet.begin(), packet.end());
      if (boot_rx_.size() >= 3 &&
          std::equal(fp::kBootProbe.begin(), fp::kBootProbe.end(), boot_rx_.end() - 3)) {
        tx_.insert(tx_.end(), fp::kBootProbeReply.begin(), fp::kBootProbeReply.end());
        boot_rx_.clear();
        mode_ = Mode::Probed;
        ++counters_.probes;
      }
      return;
    case Mode::Probed:
      if (baud_ == fp::kBaud9600) {  // the probe again: answered again
        boot_rx_.insert(boot_rx_.end(), packet.begin(), packet.end());
        if (boot_rx_.size() >= 3 &&
            std::equal(fp::kBootProbe.begin(), fp::kBootProbe.end(), boot_rx_.end() - 3)) {
          tx_.insert(tx_.end(), fp::kBootProbeReply.begin(), fp::kBootProbeReply.end());
          boot_rx_.clear();
        }
        return;
      }
      if (baud_ == fp::kBaudUpload && !dtr_ && packet.size() == 1 && packet[0] == fp::kBootEnter) {
        tx_.push_back(fp::kBootEnter);
        mode_ = Mode::Loading;
        image_.clear();
        echo_fault_this_load_ = echo_faults_ > 0;
        if (echo_faults_ > 0) --echo_faults_;
      }
      return;
    case Mode::Loading:
      if (baud_ != fp::kBaudUpload) return;
      for (const std::uint8_t b : packet) {
        image_.push_back(b);
        const bool flip = echo_fault_this_load_ && image_.size() == 100;
        tx_.push_back(flip ? std::uint8_t(b ^ 0x01) : b);
        ++counters_.echoed;
      }
      return;
    case Mode::Crashed:
      return;
    case Mode::Running:
      break;
  }
  if (baud_ != fp::kBaudRuntime) return;
  host_rx_.insert(host_rx_.end(), packet.begin(), packet.end());
  while (host_rx_.size() >= fp::kFrameSize) {
    const auto start = std::find(host_rx_.begin(), host_rx_.end(), fp::kFrameStart);
    host_rx_.erase(host_rx_.begin(), start);
    if (host_rx_.size() < fp::kFrameSize) break;
    fp::HostFrame frame;
    if (!fp::decode_host_frame(host_rx_.data(), frame)) {
      host_rx_.erase(host_rx_.begin());
      continue;
    }
    host_rx_.erase(host_rx_.begin(), host_rx_.begin() + fp::kFrameSize);
    ++counters_.frames_in;
    if ((homed_ & 7) != 7 && (frame.efforts[0] || frame.efforts[1] || frame.efforts[2]))
      ++counters_.nonzero_while_unhomed;
    efforts_ = frame.efforts;
    control_ = frame.control;
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
  fp::DeviceFrame frame;
  Vec3d t;
  if (fk::inverse(p_, t))
    for (int i = 0; i < 3; ++i) {
      const double angle = i == 0 ? t.x : (i == 1 ? t.y : t.z);
      frame.encoders[std::size_t(i)] = static_cast<std::int16_t>(
          std::lround(fk::encoder_counts(angle) + offsets_[std::size_t(i)]));
    }
  frame.buttons = buttons_;
  frame.homed = homed_;
  std::uint8_t bytes[fp::kFrameSize];
  fp::encode_device_frame(frame, bytes);
  std::size_t size = fp::kFrameSize;
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

void EmulatedFalcon::step(double dt) {
  // homing: with homing asked, a leg pulled past its index angle gets its true count
  Vec3d t;
  Vec3d index_angles;
  fk::inverse({0, 0, kIndexZ}, index_angles);
  if ((control_ & fp::kHomingMode) && fk::inverse(p_, t))
    for (int i = 0; i < 3; ++i) {
      const double angle = i == 0 ? t.x : (i == 1 ? t.y : t.z);
      const double index = i == 0 ? index_angles.x : (i == 1 ? index_angles.y : index_angles.z);
      if (angle >= index) {
        homed_ = std::uint8_t(homed_ | (1 << i));
        offsets_[std::size_t(i)] = 0.0;
      }
    }
  const int substeps = 8;
  const double h = dt / substeps;
  for (int s = 0; s < substeps; ++s) {
    Vec3d motor{};
    if (!fk::end_effector_force(p_, fk::torques_from_efforts(efforts_), motor)) motor = {};
    const Vec3d hand = hand_ ? (target_ - p_) * k_ - v_ * c_ : Vec3d{};
    const Vec3d total = motor + hand - v_ * kFriction;
    motor_force_ = motor;
    hand_force_ = hand;
    v_ += total * (1000.0 / kMassKg * h);  // N / kg = m/s^2 = 1000 mm/s^2
    const Vec3d next = p_ + v_ * h;
    Vec3d angles;
    if (std::abs(next.x) < 60 && std::abs(next.y) < 60 && next.z > 60 && next.z < 170 &&
        fk::inverse(next, angles))
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
  std::vector<std::uint8_t> packet = {0x31, 0x60};  // FTDI modem and line status
  const std::size_t n = std::min<std::size_t>(tx_.size(), fp::kUsbPacket - 2);
  packet.insert(packet.end(), tx_.begin(), tx_.begin() + static_cast<std::ptrdiff_t>(n));
  tx_.erase(tx_.begin(), tx_.begin() + static_cast<std::ptrdiff_t>(n));
  return packet;
}

}  // namespace palp::usbemu
