// palpd's Falcon options: --falcon-firmware FILE (checked at start, before the scene loads and
// before any device is awaited) and --falcon-tool-from DIR (the fixed orientation of the 3-DOF
// tool: pointing into the skin from that patient direction, default anterior). No-ops for other
// devices, which refuse the options instead.
#pragma once

#include <optional>

#include "cli_common/cli.hpp"
#include "devices/device.hpp"
#include "net/server.hpp"
#include "scene/scene.hpp"

namespace palp::app {

// Reads and checks the firmware file into a falcon device. UsageError without
// --falcon-firmware, InputError for a file that is missing, unreadable, empty or too large;
// UsageError when the options are given for another device.
void prepare_falcon(const cli::Args& args, rt::Device& device);

// Sets the falcon's fixed tool orientation (device frame) so that, placed on the patient, the
// tool points into the skin from --falcon-tool-from (default anterior).
void orient_falcon(const cli::Args& args, rt::Device& device, const Scene& scene,
                   const std::optional<net::SceneDescription::Placement>& placement);

}  // namespace palp::app
