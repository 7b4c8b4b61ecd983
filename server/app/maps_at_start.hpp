// palpd keeps only what its device can reach (--map-window): the force model runs on a window
// of the scene's maps (common/model/map_window.hpp) covering the device's reach, and the whole
// maps stay only as the render volume needs them (values, no gradient fields, no bone-beneath
// map).
//
//   reach: a placed device (usb-haptic, falcon): its workspace box at the home, in the scene,
//          widened by the margin (room for re-centres) and the tool's reach;
//          a scripted device, sim / sim:FILE (its scripted_path(), only with --map-window MM):
//          the box of its path's device positions, widened by the tool's reach and MM;
//   -> window_sampler (the scene's scheme and storage; bone-beneath traced on the whole maps)
//   -> the model's sampler; scene.fields becomes a values-only sampler of the whole maps
//      (analytic gradient, float32: the render volume samples the same values bit for bit).
//
// Re-centring moves the home (docs/frames.md): the window is not rebuilt; it is made big enough
// for re-centres within the margin (auto: 50 mm), beyond which the maps end and the tool feels
// nothing, as outside the body; palpd warns when the home leaves that room.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cli_common/cli.hpp"
#include "devices/device.hpp"
#include "model/field_sampler.hpp"
#include "model/map_window.hpp"
#include "model/registration.hpp"
#include "model/tool.hpp"
#include "net/server.hpp"
#include "scene/scene.hpp"
#include "scene/trajectory.hpp"

namespace palp::app {

inline const std::vector<std::string> kMapWindowValued = {"map-window"};

inline constexpr const char* kMapWindowHelp =
    R"(  --map-window auto|off|MM
                          keep only the maps the device can reach (docs/tuning.md): auto
                          (default) for a placed device (usb-haptic, falcon), its workspace at
                          the home plus 50 mm for re-centres; MM: that margin, and sim's path
                          plus MM too; off: the whole maps
)";

inline constexpr double kDefaultReCentreMarginMm = 50.0;

struct Box {
  Vec3d lo{}, hi{};
};

// The scene box a placed device's point reaches: its workspace (+-half, device mm) mapped by the
// registration (the 8 corners' bounding box).
Box placed_reach(const Registration& registration, const Vec3d& workspace_half);

// The box of a path's device positions.
Box path_reach(const Trajectory& path);

// The largest distance of the tool's points from its device point (mm).
double tool_reach(const Tool& tool);

struct MapsAtStart {
  std::shared_ptr<const FieldSampler> haptic;  // the model's maps: the window, or scene.fields
  bool windowed = false;
  MapWindow window;
  bool placed = false;  // a placed device (its home may move: re-centres)
  Box home_room;        // where the home may move with the device's workspace inside the window
  bool warned = false;  // warn_if_home_left_window said so already
  std::string note;     // for people and Stats: "window 163x162x326 voxels, 295.5 MiB of 3600.2"
};

// With a reach known (see the top), builds the window and replaces scene.fields by the whole
// maps' values-only sampler; otherwise returns scene.fields. UsageError for a bad --map-window.
// The reach of a device placed on the patient comes from `placement`, else from the device's
// scripted_path() (sim) with --map-window MM.
MapsAtStart maps_at_start(const cli::Args& args, const rt::Device& device, Scene& scene,
                          const std::optional<net::SceneDescription::Placement>& placement,
                          const Tool& tool, bool quiet);

// Once, on stderr: the home (after re-centres) has left the room the window was made for.
// Called off the real-time thread (palpd's main loop).
void warn_if_home_left_window(MapsAtStart& maps, const Vec3d& home);

// Bytes the sampler holds for the model (maps, gradient fields, bone-beneath map).
std::size_t haptic_map_bytes(const FieldSampler& fields);

}  // namespace palp::app
