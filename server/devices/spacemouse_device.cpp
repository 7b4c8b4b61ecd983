// The 3Dconnexion SpaceMouse device (devices/spacemouse_device.hpp): HID report parsing and the
// deflection-to-pose mapping (pure), and the device: one UsbLink per VID:PID it may be (the
// known list, or the one given), reports parsed on the libusb event thread, the newest
// deflection handed to the loop through a LatestBox, button presses through counters.
//
//   event thread: UsbLink IN packet -> on_report -> parse_report -> axes_ (merged) -> incoming_
//                                                                -> button rising edges -> counters
//   loop thread:  read() -> any link Present? -> newest axes -> PoseMapper (home / lock presses,
//                 integrate or offset, box, tilt) -> pose;  write() -> counted
#include "devices/spacemouse_device.hpp"

#include <libusb.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "base/errors.hpp"

namespace palp::rt {
namespace spacemouse {
namespace {

std::int16_t le16(const std::uint8_t* p) {
  return static_cast<std::int16_t>(static_cast<std::uint16_t>(p[0] | (p[1] << 8)));
}

// Reads `count` little-endian int16 axes into axes[first..]; false when one is implausible
// (nothing is written then).
bool read_axes(const std::uint8_t* payload, int first, int count, Axes& axes) {
  Axes next = axes;
  for (int i = 0; i < count; ++i) {
    const std::int16_t value = le16(payload + 2 * i);
    if (value > kMaxPlausibleCounts || value < -kMaxPlausibleCounts) return false;
    next[static_cast<std::size_t>(first + i)] = value;
  }
  axes = next;
  return true;
}

constexpr double kDegToRad = std::numbers::pi / 180.0;

// The rotation by the rotation vector `v` (axis × angle, radians).
Quat from_rotation_vector(const Vec3d& v) {
  const double angle = norm(v);
  if (angle < 1e-12) return {};
  return axis_angle((1.0 / angle) * v, angle);
}

// `q` with its rotation angle limited to `max_angle` (radians); w >= 0 on return.
Quat limit_angle(Quat q, double max_angle) {
  if (q.w < 0.0) q = {-q.w, -q.x, -q.y, -q.z};
  const Vec3d axis{q.x, q.y, q.z};
  const double s = norm(axis);
  const double angle = 2.0 * std::atan2(s, q.w);
  if (angle <= max_angle || s < 1e-12) return q;
  return axis_angle((1.0 / s) * axis, max_angle);
}

}  // namespace

bool is_known(usb::UsbId id) noexcept {
  return std::find(kKnownIds.begin(), kKnownIds.end(), id) != kKnownIds.end();
}

const char* to_string(ReportKind kind) {
  switch (kind) {
    case ReportKind::Translation:
      return "translation";
    case ReportKind::SixAxes:
      return "six axes";
    case ReportKind::Rotation:
      return "rotation";
    case ReportKind::Buttons:
      return "buttons";
    case ReportKind::Short:
      return "short";
    case ReportKind::Malformed:
      return "malformed";
    case ReportKind::Unknown:
      break;
  }
  return "unknown";
}

ReportKind parse_report(const std::uint8_t* data, std::size_t size, Axes& axes,
                        std::uint32_t& buttons) noexcept {
  if (size == 0) return ReportKind::Short;
  const std::size_t payload = size - 1;
  const std::uint8_t* p = data + 1;
  switch (data[0]) {
    case 1:
      if (payload < 6) return ReportKind::Short;
      if (payload < 12 && payload != 6) return ReportKind::Malformed;
      if (payload == 6)
        return read_axes(p, 0, 3, axes) ? ReportKind::Translation : ReportKind::Malformed;
      return read_axes(p, 0, 6, axes) ? ReportKind::SixAxes : ReportKind::Malformed;
    case 2:
      if (payload < 6) return ReportKind::Short;
      return read_axes(p, 3, 3, axes) ? ReportKind::Rotation : ReportKind::Malformed;
    case 3: {
      if (payload < 1) return ReportKind::Short;
      std::uint32_t mask = 0;
      for (std::size_t i = 0; i < std::min<std::size_t>(payload, 4); ++i)
        mask |= static_cast<std::uint32_t>(p[i]) << (8 * i);
      buttons = mask;
      return ReportKind::Buttons;
    }
    default:
      return ReportKind::Unknown;
  }
}

const char* to_string(Mode mode) {
  return mode == Mode::Rate ? "rate" : "position";
}

void validate(const MapperSettings& s) {
  auto check = [](double value, bool ok, const char* name) {
    if (!std::isfinite(value) || !ok)
      throw UsageError(std::string("spacemouse: ") + name + " out of range (" +
                       std::to_string(value) + ")");
  };
  check(s.deadband_counts, s.deadband_counts >= 0.0, "deadband_counts");
  check(s.full_scale_counts, s.full_scale_counts > s.deadband_counts, "full_scale_counts");
  check(s.rate_mm_s_per_count, s.rate_mm_s_per_count >= 0.0, "rate_mm_s_per_count");
  check(s.rate_deg_s_per_count, s.rate_deg_s_per_count >= 0.0, "rate_deg_s_per_count");
  check(s.position_mm_per_count, s.position_mm_per_count >= 0.0, "position_mm_per_count");
  check(s.position_deg_per_count, s.position_deg_per_count >= 0.0, "position_deg_per_count");
  check(s.box_lateral_mm, s.box_lateral_mm > 0.0, "box_lateral_mm");
  check(s.box_below_mm, s.box_below_mm > 0.0, "box_below_mm");
  check(s.box_above_mm, s.box_above_mm > 0.0, "box_above_mm");
  check(s.max_tilt_deg, s.max_tilt_deg >= 0.0 && s.max_tilt_deg <= 180.0, "max_tilt_deg");
}

PoseMapper::PoseMapper(MapperSettings settings, Pose home) : settings_(settings) {
  validate(settings_);
  set_home(home);
}

void PoseMapper::set_home(const Pose& home) {
  home_ = home;
  home_.orientation = normalized(home.orientation);
  if (!std::isfinite(home_.orientation.w) || !is_finite(home_.position))
    throw UsageError("spacemouse: the home pose is not finite");
  go_home();
}

void PoseMapper::go_home() noexcept {
  offset_ = Vec3d{};
  relative_ = Quat{};
  press_lock_ = false;
  locked_z_ = 0.0;
  compose();
}

void PoseMapper::toggle_press_lock() noexcept {
  press_lock_ = !press_lock_;
  locked_z_ = offset_.z;
}

double PoseMapper::shaped(double counts) const noexcept {
  const double magnitude = std::min(std::abs(counts), settings_.full_scale_counts);
  if (!(magnitude > settings_.deadband_counts)) return 0.0;
  return std::copysign(magnitude - settings_.deadband_counts, counts);
}

const Pose& PoseMapper::update(const Axes& axes, double dt_s) noexcept {
  // HID frame (x right, y toward the user, z down) -> user frame (x right, y away, z up).
  const Vec3d move{shaped(axes[0]), -shaped(axes[1]), -shaped(axes[2])};
  const Vec3d turn{shaped(axes[3]), -shaped(axes[4]), -shaped(axes[5])};
  const MapperSettings& s = settings_;
  if (s.mode == Mode::Rate) {
    const double dt = std::isfinite(dt_s) && dt_s > 0.0 ? dt_s : 0.0;
    offset_ += (s.rate_mm_s_per_count * dt) * move;
    if (s.rotation)
      relative_ = normalized(multiply(
          relative_, from_rotation_vector((s.rate_deg_s_per_count * kDegToRad * dt) * turn)));
  } else {
    offset_ = s.position_mm_per_count * move;
    relative_ =
        s.rotation ? from_rotation_vector((s.position_deg_per_count * kDegToRad) * turn) : Quat{};
  }
  if (press_lock_) offset_.z = locked_z_;
  offset_.x = std::clamp(offset_.x, -s.box_lateral_mm, s.box_lateral_mm);
  offset_.y = std::clamp(offset_.y, -s.box_lateral_mm, s.box_lateral_mm);
  offset_.z = std::clamp(offset_.z, -s.box_below_mm, s.box_above_mm);
  relative_ = limit_angle(relative_, s.max_tilt_deg * kDegToRad);
  compose();
  return pose_;
}

void PoseMapper::compose() noexcept {
  pose_.position = home_.position + rotate(home_.orientation, offset_);
  pose_.orientation = normalized(multiply(home_.orientation, relative_));
}

Pose home_pose(const FieldSampler& fields, const Tool& tool, double lift_mm) {
  const Trajectory path = builtin_palpation_path(fields, tool);
  if (path.empty()) throw InputError("spacemouse: no start pose found on the scene");
  Pose home = path.front().pose;
  home.position += lift_mm * rotate(home.orientation, Vec3d{0.0, 0.0, 1.0});
  return home;
}

}  // namespace spacemouse

// ---------------------------------------------------------------------------------------------
// SpaceMouseDevice

SpaceMouseDevice::SpaceMouseDevice(Options options)
    : options_(std::move(options)), mapper_(options_.mapper, options_.home.value_or(Pose{})) {
  if (options_.ids.empty())
    options_.ids.assign(spacemouse::kKnownIds.begin(), spacemouse::kKnownIds.end());
  if (!(options_.max_step_s > 0.0) || !std::isfinite(options_.max_step_s))
    throw UsageError("spacemouse: max_step_s must be positive");
}

SpaceMouseDevice::~SpaceMouseDevice() {
  for (auto& link : links_) link->stop();
}

DeviceStatus SpaceMouseDevice::configure(const DeviceConfig& config) {
  try {
    if (options_.home) {
      mapper_.set_home(*options_.home);
    } else if (config.home) {
      mapper_.set_home(*config.home);
    } else {
      if (!config.fields) return fail("spacemouse: the home pose needs a scene");
      mapper_.set_home(spacemouse::home_pose(*config.fields, config.tool, options_.home_lift_mm));
    }
  } catch (const Error& e) {
    return fail(e.what());
  }
  return DeviceStatus::Ok;
}

DeviceStatus SpaceMouseDevice::activate() {
  try {
    context_ = options_.context ? options_.context : std::make_shared<usb::UsbContext>();
    links_.clear();
    for (std::size_t i = 0; i < options_.ids.size(); ++i) {
      usb::LinkConfig config;
      config.id = options_.ids[i];
      config.interface_number = spacemouse::kInterface;
      config.in_endpoint = spacemouse::kEndpointIn;
      config.out_endpoint = 0;
      config.interrupt = true;
      config.in_packet_size = 64;
      config.in_transfers = 2;
      config.on_open = [](libusb_device_handle* handle) -> std::string {
        // Interface 0 must be HID with an interrupt IN endpoint 0x81 (a SpaceMouse's layout).
        libusb_config_descriptor* descriptor = nullptr;
        if (libusb_get_active_config_descriptor(libusb_get_device(handle), &descriptor) != 0)
          return "cannot read its configuration descriptor";
        std::string why =
            "interface 0 is not a HID interface with interrupt IN endpoint 0x81 "
            "(not a SpaceMouse?)";
        for (int n = 0; n < descriptor->bNumInterfaces; ++n) {
          const libusb_interface& itf = descriptor->interface[n];
          if (itf.num_altsetting < 1) continue;
          const libusb_interface_descriptor& alt = itf.altsetting[0];
          if (alt.bInterfaceNumber != spacemouse::kInterface ||
              alt.bInterfaceClass != LIBUSB_CLASS_HID)
            continue;
          for (int e = 0; e < alt.bNumEndpoints; ++e)
            if (alt.endpoint[e].bEndpointAddress == spacemouse::kEndpointIn &&
                (alt.endpoint[e].bmAttributes & 3) == LIBUSB_TRANSFER_TYPE_INTERRUPT)
              why.clear();
        }
        libusb_free_config_descriptor(descriptor);
        return why;
      };
      config.on_in = [this, i](const std::uint8_t* data, std::size_t size) {
        on_report(i, data, size);
      };
      config.on_close = [this, i] { on_close(i); };
      links_.push_back(std::make_unique<usb::UsbLink>(context_, std::move(config)));
    }
    for (auto& link : links_) link->start();
  } catch (const Error& e) {
    links_.clear();
    return fail(e.what());
  }
  active_ = true;
  was_present_ = false;
  return DeviceStatus::Ok;
}

DeviceStatus SpaceMouseDevice::deactivate() {
  active_ = false;
  for (auto& link : links_) link->stop();
  return DeviceStatus::Ok;
}

void SpaceMouseDevice::on_report(std::size_t link_index, const std::uint8_t* data,
                                 std::size_t size) {
  const int index = static_cast<int>(link_index);
  int owner = owner_.load(std::memory_order_relaxed);
  if (owner < 0) {
    owner = index;
    owner_.store(owner, std::memory_order_relaxed);
    axes_ = {};
    buttons_ = 0;
  }
  if (owner != index) {
    other_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  std::uint32_t buttons = buttons_;
  switch (spacemouse::parse_report(data, size, axes_, buttons)) {
    case spacemouse::ReportKind::Translation:
    case spacemouse::ReportKind::SixAxes:
    case spacemouse::ReportKind::Rotation:
      incoming_.write(axes_);
      break;
    case spacemouse::ReportKind::Buttons: {
      const std::uint32_t pressed = buttons & ~buttons_;
      // Counters first, then the mask: the loop sees a press no later than the mask.
      if (pressed & 1u) home_presses_.fetch_add(1, std::memory_order_release);
      if (pressed & 2u) lock_presses_.fetch_add(1, std::memory_order_release);
      buttons_ = buttons;
      button_mask_.store(buttons, std::memory_order_relaxed);
      break;
    }
    case spacemouse::ReportKind::Short:
      short_.fetch_add(1, std::memory_order_relaxed);
      return;
    case spacemouse::ReportKind::Malformed:
      malformed_.fetch_add(1, std::memory_order_relaxed);
      return;
    case spacemouse::ReportKind::Unknown:
      unknown_.fetch_add(1, std::memory_order_relaxed);
      return;
  }
  reports_.fetch_add(1, std::memory_order_relaxed);
}

void SpaceMouseDevice::on_close(std::size_t link_index) {
  if (owner_.load(std::memory_order_relaxed) != static_cast<int>(link_index)) return;
  // The device that was in use left: its deflection is gone with it (a second SpaceMouse that
  // is plugged in takes over with its next report).
  owner_.store(-1, std::memory_order_relaxed);
  axes_ = {};
  buttons_ = 0;
  button_mask_.store(0, std::memory_order_relaxed);
  incoming_.write(axes_);
}

DeviceStatus SpaceMouseDevice::read(std::int64_t now_ns, DeviceSample& sample) noexcept {
  if (!active_) return DeviceStatus::Disconnected;
  bool present = false;
  for (const auto& link : links_)
    if (link->state() == usb::LinkState::Present) {
      present = true;
      break;
    }
  if (!present) {
    // Absent (or refused): the deflection restarts from rest when a device comes back; button
    // presses made meanwhile are not replayed.
    was_present_ = false;
    current_ = {};
    spacemouse::Axes stale;
    incoming_.read(stale);
    home_seen_ = home_presses_.load(std::memory_order_acquire);
    lock_seen_ = lock_presses_.load(std::memory_order_acquire);
    return DeviceStatus::Absent;
  }
  double dt_s = 0.0;
  if (was_present_)
    dt_s = std::min(static_cast<double>(now_ns - last_read_ns_) * 1e-9, options_.max_step_s);
  was_present_ = true;
  last_read_ns_ = now_ns;
  incoming_.read(current_);
  const std::uint64_t home = home_presses_.load(std::memory_order_acquire);
  if (home != home_seen_) {
    home_seen_ = home;
    mapper_.go_home();
  }
  const std::uint64_t lock = lock_presses_.load(std::memory_order_acquire);
  if ((lock - lock_seen_) % 2 == 1) mapper_.toggle_press_lock();
  lock_seen_ = lock;
  sample.pose = mapper_.update(current_, dt_s);
  sample.forced_fault = 0;
  return DeviceStatus::Ok;
}

DeviceStatus SpaceMouseDevice::write(const DeviceCommand& command) noexcept {
  if (!active_) return DeviceStatus::Disconnected;
  writes_.fetch_add(1, std::memory_order_relaxed);
  force_x_.store(command.force.x, std::memory_order_relaxed);
  force_y_.store(command.force.y, std::memory_order_relaxed);
  force_z_.store(command.force.z, std::memory_order_relaxed);
  return DeviceStatus::Ok;
}

DeviceState SpaceMouseDevice::state() const noexcept {
  bool fault = false;
  for (const auto& link : links_) {
    const usb::LinkState s = link->state();
    if (s == usb::LinkState::Present) return DeviceState::Present;
    if (s == usb::LinkState::Fault) fault = true;
  }
  return fault ? DeviceState::Fault : DeviceState::Absent;
}

std::string SpaceMouseDevice::describe_ids() const {
  if (options_.ids.size() == 1) return usb::to_string(options_.ids[0]);
  return "any of " + std::to_string(options_.ids.size()) +
         " known 3Dconnexion IDs (deploy/udev/70-palp.rules)";
}

std::string SpaceMouseDevice::status_message() const {
  const std::string prefix =
      std::string("spacemouse, ") + spacemouse::to_string(options_.mapper.mode) + " mode: ";
  if (links_.empty()) return prefix + "not active";
  const usb::UsbLink* present = nullptr;
  const usb::UsbLink* fault = nullptr;
  const usb::UsbLink* seen = nullptr;  // one that was open before, or was refused
  const int owner = owner_.load(std::memory_order_relaxed);
  for (std::size_t i = 0; i < links_.size(); ++i) {
    const usb::UsbLink* link = links_[i].get();
    const usb::LinkState s = link->state();
    if (s == usb::LinkState::Present && (!present || static_cast<int>(i) == owner)) present = link;
    if (s == usb::LinkState::Fault && !fault) fault = link;
    if (link->opens() > 0 && !seen) seen = link;
  }
  std::string text;
  if (present)
    text = present->message();
  else if (fault)
    text = fault->message();
  else if (seen)
    text = seen->message() + "; waiting for " + describe_ids();
  else
    text = "waiting for a SpaceMouse: " + describe_ids();
  return prefix + text;
}

SpaceMouseDevice::Counters SpaceMouseDevice::counters() const noexcept {
  Counters c;
  c.reports = reports_.load(std::memory_order_relaxed);
  c.short_reports = short_.load(std::memory_order_relaxed);
  c.malformed = malformed_.load(std::memory_order_relaxed);
  c.unknown = unknown_.load(std::memory_order_relaxed);
  c.other_device = other_.load(std::memory_order_relaxed);
  c.home_presses = home_presses_.load(std::memory_order_relaxed);
  c.lock_presses = lock_presses_.load(std::memory_order_relaxed);
  c.writes = writes_.load(std::memory_order_relaxed);
  for (const auto& link : links_) c.opens += link->opens();
  c.buttons = button_mask_.load(std::memory_order_relaxed);
  return c;
}

Vec3d SpaceMouseDevice::last_force() const noexcept {
  return {force_x_.load(std::memory_order_relaxed), force_y_.load(std::memory_order_relaxed),
          force_z_.load(std::memory_order_relaxed)};
}

std::unique_ptr<Device> make_spacemouse_device(std::string_view arg) {
  SpaceMouseDevice::Options options;
  std::string_view rest = arg;
  auto take_mode = [&](std::string_view word, spacemouse::Mode mode) {
    if (rest.substr(0, word.size()) != word) return false;
    if (rest.size() != word.size() && rest[word.size()] != ':') return false;
    options.mapper.mode = mode;
    rest.remove_prefix(std::min(rest.size(), word.size() + 1));
    if (rest.empty() && arg.size() > word.size())
      throw UsageError("device spacemouse:" + std::string(arg) + ": VID:PID missing after ':'");
    return true;
  };
  if (!take_mode("rate", spacemouse::Mode::Rate)) take_mode("position", spacemouse::Mode::Position);
  if (!rest.empty())
    options.ids = {usb::parse_usb_id(rest, "spacemouse[:position|:rate][:VID:PID]")};
  return std::make_unique<SpaceMouseDevice>(std::move(options));
}

}  // namespace palp::rt
