// make_device and the status names; the devices live in devices/*.cpp.
#include "devices/device.hpp"

#include "base/errors.hpp"
#include "devices/falcon_device.hpp"
#include "devices/spacemouse_device.hpp"
#include "devices/usb_haptic_device.hpp"
#include "rt/recording.hpp"

namespace palp::rt {

const char* to_string(DeviceStatus status) {
  switch (status) {
    case DeviceStatus::Ok:
      return "ok";
    case DeviceStatus::NoData:
      return "no data";
    case DeviceStatus::Timeout:
      return "timeout";
    case DeviceStatus::Disconnected:
      return "disconnected";
    case DeviceStatus::Finished:
      return "finished";
    case DeviceStatus::Absent:
      return "absent";
    case DeviceStatus::Error:
      break;
  }
  return "error";
}

std::unique_ptr<Device> make_device(std::string_view spec) {
  const auto colon = spec.find(':');
  const std::string_view kind = spec.substr(0, colon);
  const std::string arg =
      colon == std::string_view::npos ? "" : std::string(spec.substr(colon + 1));
  if (kind == "sim") {
    if (colon == std::string_view::npos) return std::make_unique<SimDevice>();
    if (arg.empty()) throw UsageError("device sim:FILE needs a trajectory CSV");
    return std::make_unique<SimDevice>(read_trajectory_csv(arg));
  }
  if (kind == "replay") {
    if (arg.empty()) throw UsageError("device replay:FILE needs a recording");
    return std::make_unique<ReplayDevice>(read_recording(arg).records);
  }
  if (kind == "remote" && colon == std::string_view::npos) return std::make_unique<RemoteDevice>();
  if (kind == "usb-haptic") {
    UsbHapticDevice::Options options;
    if (colon != std::string_view::npos) options.id = usb::parse_usb_id(arg, "usb-haptic:VID:PID");
    return std::make_unique<UsbHapticDevice>(std::move(options));
  }
  if (kind == "spacemouse") return make_spacemouse_device(arg);
  if (kind == "falcon") return make_falcon_device(arg);
  throw UsageError("unknown device '" + std::string(spec) +
                   "' (sim, sim:FILE, replay:FILE, remote, usb-haptic[:VID:PID], "
                   "spacemouse[:position|:rate][:VID:PID], falcon[:INDEX])");
}

}  // namespace palp::rt
