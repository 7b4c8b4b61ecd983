// palpd's Falcon options: see falcon_options.hpp.
#include "app/falcon_options.hpp"

#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "devices/falcon_device.hpp"
#include "scene/trajectory_gen.hpp"

namespace palp::app {

void prepare_falcon(const cli::Args& args, rt::Device& device) {
  auto* falcon = dynamic_cast<rt::FalconDevice*>(&device);
  if (!falcon) {
    if (args.get("falcon-firmware") || args.get("falcon-tool-from"))
      throw UsageError("--falcon-firmware and --falcon-tool-from apply to --device falcon only");
    return;
  }
  const auto path = args.get("falcon-firmware");
  if (!path)
    throw UsageError(
        "--device falcon needs --falcon-firmware FILE: the Falcon's firmware from Novint's driver "
        "(e.g. novint.bin; palp does not ship it, docs/devices.md)");
  falcon->set_firmware(rt::FalconDevice::read_firmware(*path), *path);
  falcon->set_report_at_stop(!args.has("quiet"));
}

void orient_falcon(const cli::Args& args, rt::Device& device, const Scene& scene,
                   const std::optional<net::SceneDescription::Placement>& placement) {
  auto* falcon = dynamic_cast<rt::FalconDevice*>(&device);
  if (!falcon) return;
  const std::string from = args.get("falcon-tool-from").value_or("anterior");
  Anatomy direction{};
  if (!parse_anatomy(from, &direction))
    throw UsageError(
        "--falcon-tool-from must be a patient direction (anterior, left, right, "
        "posterior, superior, inferior), not '" +
        from + "'");
  const PatientFrame frame = patient_frame(scene.grid);
  const Anatomy along = (direction == Anatomy::Superior || direction == Anatomy::Inferior)
                            ? Anatomy::Left
                            : Anatomy::Superior;
  // tool +z = the outward normal on that side, +y toward superior (or left), in the scene frame
  const Quat scene_q = surface_orientation(frame.toward(direction), frame.toward(along));
  Quat device_q = scene_q;
  if (placement) {  // the loop turns device orientations into the scene by the registration
    const Quat r = rotation_quaternion(placement->registration.rotation);
    device_q = normalized(multiply(Quat{r.w, -r.x, -r.y, -r.z}, scene_q));
  }
  falcon->set_tool_orientation(device_q);
}

}  // namespace palp::app
