// palpd's device placement options (--home, --home-clearance, --device-axes, --device-scale,
// --workspace-mm) turned into the registration of a device that has a frame of its own, checked
// for reach before the loop starts (docs/frames.md).
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "cli_common/cli.hpp"
#include "devices/device.hpp"
#include "net/server.hpp"
#include "scene/scene.hpp"

namespace palp::app {

// "MM" or "X,Y,Z": the device's workspace, +- mm about its centre. UsageError otherwise.
Vec3d workspace_half(const std::string& text);

// The placement of a device that drives a hand from a frame of its own (its drives_a_hand():
// usb-haptic, falcon; UsageError for bad options or a workspace that cannot reach 10 mm below the
// skin at the home site); nullopt for devices that move in the scene frame (with a note on stderr
// when placement options were given, e.g. by a lab config tried with --device sim; --home is no
// such option for a device that takes_home(), the spacemouse).
std::optional<net::SceneDescription::Placement> place_device(const cli::Args& args,
                                                             const rt::Device& device,
                                                             const Scene& scene, bool quiet);

}  // namespace palp::app
