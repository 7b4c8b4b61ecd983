// palpd's run (see the header): one function a stage, in the order they happen.
#include "app/palpd_run.hpp"

#include <signal.h>
#include <time.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "app/dds_options.hpp"
#include "app/device_placement.hpp"
#include "app/falcon_options.hpp"
#include "app/igtl_options.hpp"
#include "app/maps_at_start.hpp"
#include "app/palpd_control.hpp"
#include "app/tune_at_start.hpp"
#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "cli_common/model_setup.hpp"
#include "cli_common/palpd_stats.hpp"
#include "cli_common/tls_options.hpp"
#include "devices/device.hpp"
#include "net/client_log.hpp"
#include "safety/engagement.hpp"
#include "scene/home_site.hpp"
#include "scene/structure_labels.hpp"
#include "scene/trajectory.hpp"
#include "scene/trajectory_gen.hpp"

namespace palp::app {
namespace {

// Limits: a device that pushes on a hand always gets them (the profile, or the most
// conservative class), lowered in the loop to what the device declares; engagement with them.
void choose_limits(PalpdOptions& o, const rt::Device& device) {
  if (device.drives_a_hand() && !o.profile) {
    if (o.args.has("no-force-limits")) {
      std::fprintf(stderr,
                   "palpd: WARNING: --no-force-limits: the model's raw force goes to the device, "
                   "unclamped and unramped (the skin law alone reaches 144 N at 20 mm). Keep "
                   "hands off the device.\n");
    } else {
      o.profile = device.own_profile().empty() ? &default_device_profile()
                                               : &device_profile(device.own_profile());
      if (!o.quiet)
        std::fprintf(stderr,
                     "palpd: no --device-profile: limiting the force to the %s class (%.1f N, "
                     "%.1f N/mm) and to what the device declares\n",
                     std::string(o.profile->name).c_str(), o.profile->max_force_N,
                     o.profile->max_stiffness_N_per_mm);
    }
  } else if (o.args.has("no-force-limits")) {
    throw UsageError("--no-force-limits applies to falcon and usb-haptic only");
  }
  o.loop.profile = o.profile;
  if (o.profile) {
    EngageParams engage;
    engage.ramp_s = o.args.number("engage-ramp-s", engage.ramp_s);
    validate(engage);
    o.loop.engage = engage;
    o.loop.passivity = true;
  }
}

std::unique_ptr<rt::Device> open_device(PalpdOptions& o) {
  std::unique_ptr<rt::Device> device =
      o.replay ? std::make_unique<rt::ReplayDevice>(std::move(o.replay->records))
               : rt::make_device(o.device_spec);
  app::prepare_falcon(o.args, *device);  // the firmware file, before anything is awaited
  choose_limits(o, *device);
  return device;
}

// What the loop, the server and the clients are built on.
struct Built {
  Scene scene;
  app::StartTuning tuning;
  std::shared_ptr<const Model> model;
  std::optional<net::SceneDescription::Placement> placement;  // a device placed on the patient
  app::MapsAtStart maps;
  std::shared_ptr<const StructureLabels> structures;  // what the clients draw beyond skin, bone
};

// The prep directory's vessels, artery and organs as labels for the render volume (none: empty).
std::shared_ptr<const StructureLabels> read_structures(const PalpdOptions& o, const Scene& scene) {
  auto labels =
      std::make_shared<const StructureLabels>(read_structure_labels(scene.prep_dir, scene.grid));
  if (!labels->note.empty())
    std::fprintf(stderr, "palpd: warning: structures: %s\n", labels->note.c_str());
  if (!o.quiet && !labels->structures.empty()) {
    std::string names;
    for (const StructureLabel& l : labels->structures)
      names += (names.empty() ? "" : ", ") + l.name;
    std::printf("palpd: structures for the clients: %s\n", names.c_str());
  }
  return labels;
}

// A device taking a home pose (spacemouse): at --home, --home-clearance above the skin.
Pose home_pose(const cli::Args& args, const Scene& scene) {
  const HomeSite site = find_home_site(*scene.fields, args.get("home").value_or("auto"),
                                       option_positive(args, "home-clearance", 20.0));
  Pose home;
  home.position = site.home;
  home.orientation =
      surface_orientation(site.normal, patient_frame(scene.grid).toward(Anatomy::Superior));
  return home;
}

// The scene, the tuning and the model; the device placed, configured and activated; the maps.
Built build_model(PalpdOptions& o, rt::Device& device) {
  // the port first: a port in use is told before minutes of scene preparation
  net::check_listen_address(o.server.bind, o.server.port);
  Scene scene = cli::load_scene_for(o.args, "palpd", o.quiet);
  app::StartTuning tuning =
      app::tune_at_start(o.args, scene, o.tool, o.params, o.loop.rate_hz, o.quiet);
  auto model = std::make_shared<const Model>(scene.fields, o.tool, o.params, scene.layers);

  rt::DeviceConfig device_config;
  device_config.rate_hz = o.loop.rate_hz;
  device_config.fields = scene.fields;
  device_config.tool = o.tool;
  device_config.timeout_s = std::max(o.loop.device_timeout_s, 0.01);
  // device frame -> scene: the registration of a device placed on the patient
  const std::optional<net::SceneDescription::Placement> placement =
      app::place_device(o.args, device, scene, o.quiet);
  if (placement) o.loop.registration = placement->registration;
  app::orient_falcon(o.args, device, scene, placement);
  if (device.takes_home() && (o.args.get("home") || o.args.get("home-clearance")))
    device_config.home = home_pose(o.args, scene);
  if (device.configure(device_config) != rt::DeviceStatus::Ok)
    throw InputError("device " + o.device_spec + ": " + device.last_error());
  if (device.activate() != rt::DeviceStatus::Ok)
    throw InputError("device " + o.device_spec + ": " + device.last_error());
  auto maps = app::maps_at_start(o.args, device, scene, placement, o.tool, o.quiet);
  if (maps.windowed)
    model = std::make_shared<const Model>(maps.haptic, o.tool, o.params, scene.layers);
  device_config.fields.reset();  // the whole maps' gradient fields go with the last holder
  auto structures = read_structures(o, scene);
  return Built{std::move(scene), std::move(tuning), std::move(model),
               placement,        std::move(maps),   std::move(structures)};
}

rt::RecordingMetadata recording_metadata(const PalpdOptions& o, const Built& b) {
  return {
      {"scene", *o.args.get("scene")},
      {"rate", number_text(o.loop.rate_hz)},
      {"device", o.device_spec},
      {"device-profile", o.profile ? std::string(o.profile->name) : ""},
      {"scheme", to_string(b.maps.haptic->config().gradient)},
      {"storage", to_string(b.maps.haptic->config().storage)},
      {"palp_version", PALP_VERSION},
  };
}

net::SceneDescription describe_scene(const PalpdOptions& o, const Built& b) {
  net::SceneDescription description;
  description.source = *o.args.get("scene");
  description.grid = b.scene.grid;
  description.metadata = {{"prep_dir", b.scene.prep_dir},
                          {"scheme", to_string(b.maps.haptic->config().gradient)},
                          {"storage", to_string(b.maps.haptic->config().storage)},
                          {"tuning", b.tuning.choice},
                          {"tuning_note", b.tuning.note},
                          {"maps", b.maps.note}};
  description.device = o.device_spec;
  description.device_profile = o.profile ? std::string(o.profile->name) : "";
  description.fields = b.scene.fields;
  description.ct = b.scene.ct;
  description.body = b.scene.body;
  description.structures = b.structures;
  description.placement = b.placement;
  return description;
}

// Signals are taken by sigtimedwait (wait_for_end), in this thread only: blocked before any
// thread starts.
sigset_t block_stop_signals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
  return signals;
}

void print_start(const PalpdOptions& o, const rt::HapticLoop& loop, const net::Server& server,
                 const Grid& grid) {
  if (!loop.realtime_report().empty() &&
      (!o.quiet || loop.realtime_report().rfind("warning", 0) == 0))
    std::fprintf(stderr, "palpd: %s\n", loop.realtime_report().c_str());
  if (o.quiet) return;
  std::printf("palpd: listening on %s:%u, device %s, tool %s, %.6g Hz%s\n", o.server.bind.c_str(),
              static_cast<unsigned>(server.port()), o.device_spec.c_str(), o.tool.name.c_str(),
              o.loop.rate_hz,
              o.profile ? (std::string(", profile ") + std::string(o.profile->name)).c_str() : "");
  const PatientFrame frame = patient_frame(grid);
  for (const std::string& line : cli::server_tls_report(o.server.tls.get(), o.server.bind))
    std::fprintf(line.rfind("warning", 0) == 0 ? stderr : stdout, "palpd: %s\n", line.c_str());
  if (o.server.token.empty() && !net::is_loopback_address(o.server.bind))
    std::printf(
        "palpd: WARNING: listening beyond this machine without --token: anyone who can "
        "reach %s:%u may become the controller (set 'token' in the config)\n",
        o.server.bind.c_str(), static_cast<unsigned>(server.port()));
  std::printf("palpd: patient stored %s: anterior is %s in the scene frame\n",
              frame.orientation_code().c_str(),
              to_string(frame.nearest_axis(Anatomy::Anterior)).c_str());
  std::fflush(stdout);
}

// Until the loop finishes, a signal comes (returned: SIGINT, SIGTERM; 0 otherwise) or
// --duration passes.
int wait_for_end(const PalpdOptions& o, const rt::HapticLoop& loop, const rt::Device& device,
                 app::MapsAtStart& maps, const sigset_t& signals, std::int64_t start_ns) {
  // Hot-plug devices come and go: say so once per change (with the device's own words, e.g. the
  // udev rule to install), not once per tick.
  std::string device_report;
  while (!loop.finished()) {
    const std::string report = std::string("device ") + rt::to_string(loop.device_state()) + ": " +
                               device.status_message();
    if (report != device_report && !device.status_message().empty()) {
      device_report = report;
      if (!o.quiet || loop.device_state() == rt::DeviceState::Fault)
        std::fprintf(stderr, "palpd: %s\n", report.c_str());
    }
    app::warn_if_home_left_window(maps, loop.registration_home());
    timespec wait{0, 100'000'000};
    const int sig = sigtimedwait(&signals, nullptr, &wait);
    if (sig == SIGINT || sig == SIGTERM) return sig;
    if (o.duration_s > 0 &&
        static_cast<double>(rt::monotonic_ns() - start_ns) * 1e-9 >= o.duration_s)
      break;
  }
  return 0;
}

void print_end(const PalpdOptions& o, const rt::LoopStats& s, const net::ServerCounters& c,
               int exit_signal) {
  if (!o.quiet) {
    std::printf(
        "palpd: %llu ticks, %llu overruns, %llu faults, max lateness %.1f us, "
        "mean tick %.2f us; %llu clients served, %llu frames sent, %llu dropped%s\n",
        static_cast<unsigned long long>(s.ticks), static_cast<unsigned long long>(s.overruns),
        static_cast<unsigned long long>(s.faults), static_cast<double>(s.max_late_ns) * 1e-3,
        s.ticks ? static_cast<double>(s.tick_ns_sum) * 1e-3 / static_cast<double>(s.ticks) : 0.0,
        static_cast<unsigned long long>(c.accepted), static_cast<unsigned long long>(c.frames_sent),
        static_cast<unsigned long long>(c.frames_dropped), exit_signal ? " (signal)" : "");
  }
  if (s.record_dropped > 0)
    std::fprintf(stderr, "palpd: warning: the recording lost %llu ticks\n",
                 static_cast<unsigned long long>(s.record_dropped));
}

// A running training session ends with palpd: scored, its report written and named.
void finish_task(const PalpdOptions& o, net::TaskSession& task) {
  task.finish();
  if (!task.view().report.empty() && !o.quiet)
    std::printf("palpd: task report %s\n", task.view().report.c_str());
  if (!task.view().note.empty() && !o.quiet)
    std::fprintf(stderr, "palpd: task: %s\n", task.view().note.c_str());
}

// The loop, the server and its bridges, from start to stop.
int serve(PalpdOptions& o, rt::Device& device, Built& b) {
  const sigset_t signals = block_stop_signals();
  rt::HapticLoop loop(b.model, device, o.loop);
  app::PalpdControl app(loop, b.maps.haptic, device, recording_metadata(o, b), o.record_dir);
  const net::SceneDescription description = describe_scene(o, b);
  app::DdsControlGate control(app);  // palp.v1's and DDS's device poses, one at a time
  net::Server server(o.server, description, loop, &control);
  const auto igtl = app::igtl_beside(o.args, b.scene.grid, o.loop.rate_hz, server, o.quiet);
  const auto dds =
      app::dds_beside(o.args, description, loop, control, server, o.tool.name, o.quiet);
  const auto task =
      app::task_beside(std::move(o.task), b.scene.grid, app, server, o.replay_path, o.quiet);

  if (const auto record = o.args.get("record")) {
    const std::string failure = app.start(*record, "palpd --record");
    if (!failure.empty()) throw Error(failure);
  }
  loop.start();
  server.start();
  print_start(o, loop, server, b.scene.grid);

  const std::int64_t start_ns = rt::monotonic_ns();
  const int exit_signal = wait_for_end(o, loop, device, b.maps, signals, start_ns);
  if (loop.finished()) {
    // Let the network thread pass on the last frames before it stops.
    timespec pause{0, 50'000'000};
    nanosleep(&pause, nullptr);
  }
  server.stop();
  loop.stop();                      // the device gets zero force
  if (task) finish_task(o, *task);  // the io thread has stopped: the session is this thread's
  if (app.recording()) app.stop_recording();
  device.deactivate();

  const rt::LoopStats s = loop.stats();
  const net::ServerCounters c = server.counters();
  if (!o.stats_json.empty())
    cli::write_stats_json(o.stats_json, s, c, o.loop.rate_hz,
                          static_cast<double>(rt::monotonic_ns() - start_ns) * 1e-9);
  print_end(o, s, c, exit_signal);
  return 0;
}

}  // namespace

int run_palpd(PalpdOptions& o) {
  std::unique_ptr<rt::Device> device = open_device(o);
  Built built = build_model(o, *device);
  return serve(o, *device, built);
}

}  // namespace palp::app
