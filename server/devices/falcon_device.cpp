// The Novint Falcon (devices/falcon_device.hpp): FTDI setup, firmware load and runtime exchange
// on the libusb event thread; lock-free hand-off to and from the haptic loop.
#include "devices/falcon_device.hpp"

#include <libusb.h>
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>

#include "base/errors.hpp"

namespace palp::rt {

namespace fp = usb::falcon;

namespace {

std::int64_t clock_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::string hex(std::uint8_t v) {
  static const char* digits = "0123456789abcdef";
  return std::string("0x") + digits[v >> 4] + digits[v & 15];
}

// Synchronous FTDI helpers for the setup (event thread, between event passes).
struct Port {
  libusb_device_handle* handle;
  std::string error;

  bool control(std::uint8_t request, std::uint16_t value, const char* what) {
    const int rc =
        libusb_control_transfer(handle, fp::kFtdiRequestType, request, value, 0, nullptr, 0, 1000);
    if (rc < 0) error = std::string("FTDI ") + what + " failed: " + usb::error_text(rc);
    return rc >= 0;
  }
  bool write(const std::uint8_t* data, std::size_t size) {
    int done = 0;
    const int rc = libusb_bulk_transfer(handle, fp::kEndpointOut, const_cast<std::uint8_t*>(data),
                                        static_cast<int>(size), &done, 1000);
    if (rc != 0 || done != static_cast<int>(size)) {
      error = "writing to the Falcon failed: " + usb::error_text(rc);
      return false;
    }
    return true;
  }
  // Up to `want` serial bytes (status bytes stripped) within timeout_ms; returns how many.
  std::size_t read(std::uint8_t* out, std::size_t want, int timeout_ms) {
    std::size_t got = 0;
    const std::int64_t end = clock_ns() + std::int64_t(timeout_ms) * 1'000'000;
    std::uint8_t packet[fp::kUsbPacket];
    while (got < want && clock_ns() < end) {
      int n = 0;
      const int rc = libusb_bulk_transfer(handle, fp::kEndpointIn, packet, sizeof packet, &n, 20);
      if (rc == LIBUSB_ERROR_TIMEOUT) continue;
      if (rc != 0) {
        error = "reading from the Falcon failed: " + usb::error_text(rc);
        return got;
      }
      const std::uint8_t* data = nullptr;
      std::size_t size = 0;
      if (!fp::strip_ftdi_status(packet, static_cast<std::size_t>(n), data, size)) continue;
      const std::size_t take = std::min(size, want - got);
      std::memcpy(out + got, data, take);
      got += take;
    }
    return got;
  }
  bool purge() {
    return control(fp::kSioReset, fp::kPurgeRx, "purge RX") &&
           control(fp::kSioReset, fp::kPurgeTx, "purge TX");
  }
  // Runtime line settings: 1 ms latency, runtime baud, 8N1, no flow control, purged.
  bool runtime_mode() {
    return control(fp::kSioSetLatency, fp::kLatencyRuntime, "latency timer") &&
           control(fp::kSioSetBaudRate, fp::kBaudRuntime, "baud rate") &&
           control(fp::kSioSetData, fp::kData8N1, "8N1") &&
           control(fp::kSioSetFlowCtrl, 0, "flow control") && purge();
  }
};

}  // namespace

std::vector<std::uint8_t> FalconDevice::read_firmware(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file)
    throw InputError("--falcon-firmware " + path +
                     ": cannot open it (palp does not ship the Falcon firmware: use the file from "
                     "Novint's driver, e.g. novint.bin; docs/devices.md)");
  std::vector<std::uint8_t> image;
  char buffer[4096];
  while (file) {
    file.read(buffer, sizeof buffer);
    image.insert(image.end(), buffer, buffer + file.gcount());
    if (image.size() > fp::kMaxFirmwareBytes)
      throw InputError("--falcon-firmware " + path + ": larger than " +
                       std::to_string(fp::kMaxFirmwareBytes / 1024) +
                       " KiB, not a Falcon firmware image");
  }
  if (file.bad()) throw InputError("--falcon-firmware " + path + ": read error");
  if (image.empty()) throw InputError("--falcon-firmware " + path + ": the file is empty");
  return image;
}

FalconDevice::FalconDevice(Options options) : options_(std::move(options)) {}

FalconDevice::~FalconDevice() {
  if (link_) link_->stop();
}

void FalconDevice::set_firmware(std::vector<std::uint8_t> image, std::string path) {
  options_.firmware = std::move(image);
  options_.firmware_path = std::move(path);
}

DeviceStatus FalconDevice::configure(const DeviceConfig& /*config*/) {
  if (options_.firmware.empty())
    return fail("the Falcon needs its firmware: --falcon-firmware FILE (docs/devices.md)");
  return DeviceStatus::Ok;
}

DeviceStatus FalconDevice::activate() {
  if (options_.firmware.empty())
    return fail("the Falcon needs its firmware: --falcon-firmware FILE (docs/devices.md)");
  try {
    context_ = options_.context ? options_.context : std::make_shared<usb::UsbContext>();
    usb::LinkConfig config;
    config.id = {fp::kVendor, fp::kProduct};
    config.match_index = options_.index;
    config.interface_number = 0;
    config.in_endpoint = fp::kEndpointIn;
    config.out_endpoint = fp::kEndpointOut;
    config.interrupt = false;
    config.in_packet_size = fp::kUsbPacket;
    config.out_packet_size = fp::kFrameSize;
    config.in_transfers = 2;
    config.out_transfers = 4;
    config.on_open = [this](libusb_device_handle* handle) { return setup(handle); };
    config.on_in = [this](const std::uint8_t* data, std::size_t size) { on_packet(data, size); };
    config.on_close = [this] {  // unplugged or stopped: homing is lost with the power
      device_homed_ = 0;
      awaiting_ = false;
      homed_bits_.store(0, std::memory_order_relaxed);
    };
    link_ = std::make_unique<usb::UsbLink>(context_, std::move(config));
    link_->start();
  } catch (const Error& e) {
    return fail(e.what());
  }
  active_ = true;
  activated_ns_ = clock_ns();
  return DeviceStatus::Ok;
}

DeviceStatus FalconDevice::deactivate() {
  const bool was_active = active_;
  active_ = false;
  if (link_) {
    context_->run_sync([this] { send_frame({0, 0, 0}, clock_ns()); });  // the force off, then close
    link_->stop();
  }
  if (was_active && report_at_stop_) {
    const Counters c = counters();
    const double s = double(clock_ns() - activated_ns_) * 1e-9;
    std::fprintf(
        stderr,
        "palpd: falcon: %llu exchanges in %.1f s (%.0f/s), %llu lost replies, %llu "
        "corrupt and %llu short frames, %llu firmware loads (%llu failed), %llu opens\n",
        static_cast<unsigned long long>(c.frames), s, s > 0 ? double(c.frames) / s : 0.0,
        static_cast<unsigned long long>(c.lost_replies), static_cast<unsigned long long>(c.corrupt),
        static_cast<unsigned long long>(c.short_frames), static_cast<unsigned long long>(c.uploads),
        static_cast<unsigned long long>(c.upload_failures),
        static_cast<unsigned long long>(c.opens));
  }
  return DeviceStatus::Ok;
}

// A probe frame (zero efforts, homing asked) answered within `tries` x 50 ms: firmware running.
// A Falcon answers within a few ms; the margin is for a busy host (and the test emulator), and
// costs only a device without firmware, once, before its upload.
bool FalconDevice::answers_frames(libusb_device_handle* handle, int tries) {
  Port port{handle, {}};
  fp::FrameParser parser;
  std::uint8_t frame[fp::kFrameSize];
  fp::encode_host_frame({{0, 0, 0}, fp::kHomingMode | fp::kLedRed}, frame);
  for (int i = 0; i < tries; ++i) {
    if (!port.write(frame, sizeof frame)) return false;
    std::uint8_t reply[2 * fp::kFrameSize];
    const std::size_t got = port.read(reply, sizeof reply, 50);
    bool answered = false;
    parser.feed(reply, got, [&](const fp::DeviceFrame&) { answered = true; });
    if (answered) return true;
  }
  return false;
}

namespace {

// The bootloader's echo of kBootEnter. An answer to an earlier probe may come first: the probe
// loop waits 100 ms for each and probes again, so on a loaded host the device's answer to the
// first can arrive after the loop gave up on it, and the second answer then waits in the FIFO
// (libnifalcon waits a second for each and never probes twice this fast). Its bytes, and the
// leading 0x00 some hosts see, are passed over, at most two answers' worth; any other byte is
// the failure, in `echo`.
bool read_boot_echo(Port& port, std::uint8_t& echo) {
  constexpr int kMostSkipped = 2 * static_cast<int>(fp::kBootProbeReply.size() + 1);
  for (int skipped = 0; skipped <= kMostSkipped; ++skipped) {
    if (port.read(&echo, 1, 200) != 1) return false;
    if (echo == fp::kBootEnter) return true;
    const bool probe_answer =
        echo == 0x00 || std::find(fp::kBootProbeReply.begin(), fp::kBootProbeReply.end(), echo) !=
                            fp::kBootProbeReply.end();
    if (!probe_answer) return false;
  }
  return false;
}

}  // namespace

std::string FalconDevice::upload(libusb_device_handle* handle) {
  Port port{handle, {}};
  // Bootloader: 16 ms latency, 9600 baud 8N1, no flow control, RTS low, DTR low -> high (reset)
  if (!port.purge() || !port.control(fp::kSioSetLatency, fp::kLatencyBoot, "latency timer") ||
      !port.control(fp::kSioSetBaudRate, fp::kBaud9600, "baud rate") ||
      !port.control(fp::kSioSetData, fp::kData8N1, "8N1") ||
      !port.control(fp::kSioSetFlowCtrl, 0, "flow control") ||
      !port.control(fp::kSioModemCtrl, fp::kRtsLow, "RTS") ||
      !port.control(fp::kSioModemCtrl, fp::kDtrLow, "DTR") ||
      !port.control(fp::kSioModemCtrl, fp::kDtrHigh, "DTR"))
    return port.error;
  bool probed = false;
  for (int i = 0; i < 10 && !probed; ++i) {
    if (!port.write(fp::kBootProbe.data(), fp::kBootProbe.size())) return port.error;
    std::uint8_t reply[8] = {};
    std::size_t got = port.read(reply, 4, 100);
    if (got > 0 && reply[0] == 0x00) {  // a leading 0x00 some hosts see
      std::memmove(reply, reply + 1, got - 1);
      got = got - 1 + port.read(reply + got - 1, 1, 50);
    }
    probed = got == 4 && std::equal(fp::kBootProbeReply.begin(), fp::kBootProbeReply.end(), reply);
  }
  if (!probed)
    return "bootloader handshake failed: no answer to the probe after a DTR reset (is the "
           "Falcon's power supply plugged in?)";
  if (!port.control(fp::kSioModemCtrl, fp::kDtrLow, "DTR") ||
      !port.control(fp::kSioSetBaudRate, fp::kBaudUpload, "baud rate"))
    return port.error;
  const std::uint8_t enter = fp::kBootEnter;
  if (!port.write(&enter, 1)) return port.error;
  std::uint8_t echo = 0;
  if (!read_boot_echo(port, echo))
    return "bootloader handshake failed: 'A' not echoed (got " +
           (port.error.empty() ? hex(echo) : port.error) + ")";
  const std::vector<std::uint8_t>& image = options_.firmware;
  std::uint8_t back[fp::kFirmwareChunk];
  for (std::size_t at = 0; at < image.size(); at += fp::kFirmwareChunk) {
    const std::size_t n = std::min(fp::kFirmwareChunk, image.size() - at);
    if (!port.write(image.data() + at, n)) return port.error;
    const std::size_t got = port.read(back, n, 500);
    for (std::size_t i = 0; i < got; ++i)
      if (back[i] != image[at + i])
        return "firmware echo mismatch at byte " + std::to_string(at + i) + " of " +
               std::to_string(image.size()) + " (sent " + hex(image[at + i]) + ", got " +
               hex(back[i]) + ")";
    if (got != n)
      return "firmware echo cut short at byte " + std::to_string(at + got) + " of " +
             std::to_string(image.size());
  }
  if (!port.runtime_mode()) return port.error;
  if (!answers_frames(handle, 10))
    return "firmware " + options_.firmware_path + " loaded and echoed, but the Falcon does not " +
           "answer runtime frames: is it Novint's Falcon firmware (novint.bin)?";
  return {};
}

std::string FalconDevice::setup(libusb_device_handle* handle) {
  Port port{handle, {}};
  if (!port.control(fp::kSioReset, 0, "reset") || !port.runtime_mode()) return port.error;
  bool running = answers_frames(handle, 5);
  std::string why;
  if (running) {
    already_running_.fetch_add(1, std::memory_order_relaxed);
    set_note("firmware already running");
  } else {
    for (int attempt = 1; attempt <= std::max(options_.upload_attempts, 1); ++attempt) {
      why = upload(handle);
      if (why.empty()) {
        uploads_.fetch_add(1, std::memory_order_relaxed);
        set_note("firmware " + options_.firmware_path + " loaded (" +
                 std::to_string(options_.firmware.size()) + " bytes, attempt " +
                 std::to_string(attempt) + ")");
        running = true;
        break;
      }
      upload_failures_.fetch_add(1, std::memory_order_relaxed);
    }
    if (!running)
      return "firmware load failed after " + std::to_string(std::max(options_.upload_attempts, 1)) +
             " attempts: " + why;
  }
  if (!port.runtime_mode()) return port.error;
  parser_.reset();
  awaiting_ = false;
  device_homed_ = 0;
  homed_.store(false, std::memory_order_relaxed);
  homed_bits_.store(0, std::memory_order_relaxed);
  Outgoing stale;
  commands_.read(stale);  // a command from before the replug is not sent
  last_command_ns_ = sent_ns_ = clock_ns();
  opens_.fetch_add(1, std::memory_order_relaxed);
  return {};
}

void FalconDevice::send_frame(const std::array<std::int16_t, 3>& efforts, std::int64_t now) {
  if (!link_) return;
  const bool homed = (device_homed_ & 7) == 7;
  fp::HostFrame frame;
  // never any effort before the firmware says homed
  if (homed) frame.efforts = efforts;
  frame.control = homed ? fp::kLedGreen : std::uint8_t(fp::kLedRed | fp::kHomingMode);
  if (homed && (device_buttons_ & (fp::kButtonCentre | fp::kButtonForward)))
    frame.control |= fp::kLedBlue;
  std::uint8_t bytes[fp::kFrameSize];
  fp::encode_host_frame(frame, bytes);
  if (link_->send(bytes, sizeof bytes)) {
    host_frames_.fetch_add(1, std::memory_order_relaxed);
    awaiting_ = true;
    sent_ns_ = now;
    for (int i = 0; i < 3; ++i)
      last_efforts_packed_[i].store(static_cast<std::uint16_t>(frame.efforts[std::size_t(i)]),
                                    std::memory_order_relaxed);
  }
}

void FalconDevice::on_packet(const std::uint8_t* data, std::size_t size) {
  const std::uint8_t* serial = nullptr;
  std::size_t serial_size = 0;
  if (!fp::strip_ftdi_status(data, size, serial, serial_size)) {
    short_packets_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const std::int64_t now = clock_ns();
  parser_.feed(serial, serial_size, [&](const fp::DeviceFrame& frame) {
    Incoming in;
    in.encoders = frame.encoders;
    in.buttons = frame.buttons;
    in.homed = frame.homed;
    device_homed_ = frame.homed;
    device_buttons_ = frame.buttons;
    buttons_.store(frame.buttons, std::memory_order_relaxed);
    homed_bits_.store(frame.homed, std::memory_order_relaxed);
    incoming_.write(in);
    awaiting_ = false;
  });
  const auto& c = parser_.counters();
  frames_.store(c.frames, std::memory_order_relaxed);
  corrupt_.store(c.corrupt, std::memory_order_relaxed);
  short_frames_.store(c.short_frames, std::memory_order_relaxed);

  if (awaiting_) {
    if (now - sent_ns_ < std::int64_t(options_.reply_timeout_ms) * 1'000'000) return;
    lost_.fetch_add(1, std::memory_order_relaxed);  // no reply: send again
    awaiting_ = false;
  }
  Outgoing out;
  if (commands_.read(out)) {
    last_command_ns_ = now;
    send_frame(out.efforts, now);
  } else if (now - last_command_ns_ >= std::int64_t(options_.stall_ms) * 1'000'000) {
    // the loop is not commanding (stopped, stalled, or not started): zero effort, and the
    // exchange goes on so that homing and the buttons are still seen
    zero_frames_.fetch_add(1, std::memory_order_relaxed);
    send_frame({0, 0, 0}, now);
  }
}

DeviceStatus FalconDevice::read(std::int64_t /*now_ns*/, DeviceSample& sample) noexcept {
  if (!active_ || !link_) return DeviceStatus::Disconnected;
  if (link_->state() != usb::LinkState::Present) {
    Incoming stale;
    incoming_.read(stale);  // frames from before the loss are not used after a replug
    homed_.store(false, std::memory_order_relaxed);
    clutch_ = recentre_ = false;
    clutch_offset_ = {};
    held_off_ = true;  // after a replug: absent until a frame says homed
    return DeviceStatus::Absent;
  }
  Incoming in;
  // between frames, a held-off device stays absent (one absent period, not one per frame)
  if (!incoming_.read(in)) return held_off_ ? DeviceStatus::Absent : DeviceStatus::NoData;
  const bool homed = (in.homed & 7) == 7;
  homed_.store(homed, std::memory_order_relaxed);
  held_off_ = true;
  if (!homed) return DeviceStatus::Absent;  // no force until homed
  const Vec3d angles{falcon::joint_angle(in.encoders[0]), falcon::joint_angle(in.encoders[1]),
                     falcon::joint_angle(in.encoders[2])};
  Vec3d p;
  if (!falcon::forward(angles, falcon_pos_, p)) {
    fk_failures_.fetch_add(1, std::memory_order_relaxed);
    return DeviceStatus::NoData;
  }
  falcon_pos_ = p;
  pos_[0].store(p.x, std::memory_order_relaxed);
  pos_[1].store(p.y, std::memory_order_relaxed);
  pos_[2].store(p.z, std::memory_order_relaxed);
  const Vec3d device_pos = p - falcon::kWorkspaceCentre;
  if (in.buttons & fp::kButtonCentre) {  // clutch: the tool stays, the handle moves
    if (!clutch_) frozen_ = last_device_pos_;
    clutch_ = true;
    clutch_offset_ = device_pos - frozen_;
    return DeviceStatus::Absent;
  }
  if (in.buttons & fp::kButtonForward) {  // re-centre: released, the tool is at the home point
    clutch_ = true;                       // (no force while held; the loop ramps in after)
    recentre_ = true;
    return DeviceStatus::Absent;
  }
  if (recentre_) {
    clutch_offset_ = device_pos;
    recentre_ = false;
    recentres_.fetch_add(1, std::memory_order_relaxed);
  }
  clutch_ = false;
  held_off_ = false;
  last_device_pos_ = device_pos - clutch_offset_;
  sample.pose.position = last_device_pos_;
  sample.pose.orientation = options_.tool_orientation;
  sample.forced_fault = 0;
  return DeviceStatus::Ok;
}

DeviceStatus FalconDevice::write(const DeviceCommand& command) noexcept {
  if (!active_ || !link_) return DeviceStatus::Disconnected;
  Outgoing out;
  if (homed_.load(std::memory_order_relaxed) && !clutch_) {
    // the last guard: never more than the declared 8 N, the direction kept; then no motor beyond
    // the firmware's effort cap (falcon::kMaxEffort), the direction kept again and the command
    // counted (Stats.device_force_limited). Torque is not rendered (3-DOF), clients still show it
    Vec3d force = is_finite(command.force) ? command.force : Vec3d{};
    const double limit = declared_limits().max_force_N;
    if (norm(force) > limit) force = force * (limit / norm(force));
    const falcon::Efforts e = falcon::efforts_for_force(falcon_pos_, force);
    if (e.clamped) clamped_.fetch_add(1, std::memory_order_relaxed);
    out.efforts = e.value;
  }
  commands_.write(out);
  return DeviceStatus::Ok;
}

DeviceState FalconDevice::state() const noexcept {
  if (!link_) return DeviceState::Absent;
  switch (link_->state()) {
    case usb::LinkState::Present:
      return homed_.load(std::memory_order_relaxed) ? DeviceState::Present : DeviceState::Absent;
    case usb::LinkState::Fault:
      return DeviceState::Fault;
    case usb::LinkState::Absent:
    case usb::LinkState::Unknown:  // a link is never unknown
      break;
  }
  return DeviceState::Absent;
}

usb::LinkState FalconDevice::link_state() const noexcept {
  return link_ ? link_->state() : usb::LinkState::Absent;
}

Vec3d FalconDevice::falcon_position() const noexcept {
  return {pos_[0].load(std::memory_order_relaxed), pos_[1].load(std::memory_order_relaxed),
          pos_[2].load(std::memory_order_relaxed)};
}

void FalconDevice::set_note(std::string note) {
  const std::lock_guard lock(note_mutex_);
  setup_note_ = std::move(note);
}

std::string FalconDevice::status_message() const {
  if (!link_) return "falcon not active";
  std::string text = link_->message();
  if (link_->state() != usb::LinkState::Present) return text;
  {
    const std::lock_guard lock(note_mutex_);
    if (!setup_note_.empty()) text += "; " + setup_note_;
  }
  const std::uint8_t bits = homed_bits_.load(std::memory_order_relaxed);
  if ((bits & 7) != 7) {
    text +=
        "; homing (red LED): pull the handle all the way out, then push it straight in "
        "(motors homed:";
    for (int i = 0; i < 3; ++i) text += (bits >> i) & 1 ? " yes" : " no";
    text += ")";
  } else {
    text += "; homed (green LED)";
    const std::uint8_t buttons = buttons_.load(std::memory_order_relaxed);
    if (buttons & fp::kButtonCentre) text += "; clutch held (no force)";
    if (buttons & fp::kButtonForward) text += "; re-centre held (no force until released)";
  }
  return text;
}

FalconDevice::Counters FalconDevice::counters() const noexcept {
  Counters c;
  c.frames = frames_.load(std::memory_order_relaxed);
  c.corrupt = corrupt_.load(std::memory_order_relaxed);
  c.short_frames = short_frames_.load(std::memory_order_relaxed);
  c.short_packets = short_packets_.load(std::memory_order_relaxed);
  c.host_frames = host_frames_.load(std::memory_order_relaxed);
  c.zero_frames = zero_frames_.load(std::memory_order_relaxed);
  c.lost_replies = lost_.load(std::memory_order_relaxed);
  c.clamped = clamped_.load(std::memory_order_relaxed);
  c.fk_failures = fk_failures_.load(std::memory_order_relaxed);
  c.uploads = uploads_.load(std::memory_order_relaxed);
  c.upload_failures = upload_failures_.load(std::memory_order_relaxed);
  c.already_running = already_running_.load(std::memory_order_relaxed);
  c.opens = opens_.load(std::memory_order_relaxed);
  c.recentres = recentres_.load(std::memory_order_relaxed);
  c.buttons = buttons_.load(std::memory_order_relaxed);
  c.homed = homed_bits_.load(std::memory_order_relaxed);
  for (int i = 0; i < 3; ++i)
    c.last_efforts[std::size_t(i)] =
        static_cast<std::int16_t>(last_efforts_packed_[i].load(std::memory_order_relaxed));
  return c;
}

std::unique_ptr<Device> make_falcon_device(std::string_view arg) {
  FalconDevice::Options options;
  if (!arg.empty()) {
    unsigned index = 0;
    for (const char c : arg) {
      if (c < '0' || c > '9' || index > 100)
        throw UsageError("falcon:INDEX needs a small number (0 = the first Falcon), not '" +
                         std::string(arg) + "'");
      index = index * 10 + unsigned(c - '0');
    }
    if (index > 15) throw UsageError("falcon:INDEX must be 0..15");
    options.index = index;
  }
  return std::make_unique<FalconDevice>(std::move(options));
}

}  // namespace palp::rt
