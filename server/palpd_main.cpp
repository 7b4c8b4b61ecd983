// palpd — the real-time haptic server.
//   scene + tool + parameters -> Model; DEVICE -> HapticLoop (its own thread, --rate HZ) ->
//   snapshot ring -> Server (Asio io thread) -> clients; record ring -> Recorder (--record FILE)
// Configuration: a TOML file (--config FILE) whose keys are the long option names; the command
// line overrides it. Errors print one line and exit 1 (failure) or 2 (usage).
#include <signal.h>
#include <time.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "cli/cli.hpp"
#include "cli/config_file.hpp"
#include "cli/dds_options.hpp"
#include "cli/device_placement.hpp"
#include "cli/falcon_options.hpp"
#include "cli/maps_at_start.hpp"
#include "cli/model_setup.hpp"
#include "cli/palpd_control.hpp"
#include "cli/palpd_stats.hpp"
#include "cli/rt_options.hpp"
#include "cli/tls_options.hpp"
#include "cli/tune_at_start.hpp"
#include "dds_common.hpp"
#include "devices/device.hpp"
#include "interop/igtl_options.hpp"
#include "io/gzip.hpp"
#include "loop/haptic_loop.hpp"
#include "model/force_model.hpp"
#include "model/registration.hpp"
#include "net/client_log.hpp"
#include "net/server.hpp"
#include "rt/recording.hpp"
#include "safety/engagement.hpp"
#include "safety/safety.hpp"
#include "scene/home_site.hpp"
#include "scene/trajectory.hpp"
#include "scene/trajectory_gen.hpp"

namespace palp {
namespace {

constexpr const char* kUsage =
    R"(usage: palpd --scene SCENE --device DEVICE [--port P] [--rate HZ] [options]

The real-time haptic server: runs the force model at a fixed rate on a dedicated thread, drives
the device, and streams frames to clients over TCP (palp.v1, proto/palp.proto).

Devices:
  sim                     the built-in palpation path for the scene, looping (torso: press,
                          slide across the ribs, lift; other scenes: press, slide, hold, lift)
  sim:FILE                a trajectory CSV (t,px,py,pz,qw,qx,qy,qz) at its timestamps, looping
  replay:FILE             a palpd recording, tick by tick, reproducing its forces exactly; scene,
                          tool, rate, profile and parameters default to the recording's; a
                          recording cut inside a record is refused (--allow-truncated: replay
                          its whole ticks, with a warning)
  remote                  the pose comes from the CONTROLLER client (DevicePose messages)
  usb-haptic[:VID:PID]    a USB force-feedback device speaking the open haptic protocol
                          (docs/usb-protocol.md; VID:PID in hex, default 1209:0001); hot-plug:
                          it may come after palpd starts and go at any time (zero force while
                          absent); a permission error names the udev rule to install
  falcon[:INDEX]          a Novint Falcon on libusb (INDEX: which one, default 0), with
                          --falcon-firmware FILE; homed by the user, hot-plug (docs/devices.md)
  spacemouse[:position|:rate][:VID:PID]
                          a 3Dconnexion SpaceMouse as a pose source (no force output: clients
                          show the force it cannot render); rate (default) moves the finger
                          while the cap is deflected, position offsets it from --home

Options:
)";

constexpr const char* kOptions = R"(  --device DEVICE         see above (required)
  --tool TOOL             finger:N, twofinger:N, probe:NXxNY (default finger:37)
  --param NAME=VALUE      force parameter override, repeatable (as in palp run)
  --device-profile NAME   safety limits after the model: touch, falcon, phantom-premium,
                          omega. A device that pushes on a hand (usb-haptic) always gets
                          limits: this profile, lowered to what the device declares (GET_INFO);
                          without one, the most conservative class (touch: 3.3 N). sim, replay
                          and remote apply limits only when a profile is named.
  --engage-ramp-s S       with limits: after start and every fault, replug, tool, parameter or
                          scene change and unpause, no force until it is below 0.2 N, then a
                          ramp over S seconds (default 1.5)
  --NO-FORCE-LIMITS       (spelled --no-force-limits) send the model's raw force to a usb-haptic
                          device: no clamp, no step bound, no engagement. Command line only,
                          never in a config file; for bench tests with no hand on the device
  --falcon-firmware FILE  Novint's Falcon firmware (from its driver; palp does not ship it)
  --falcon-tool-from DIR  the Falcon's fixed tool points into the skin from DIR (anterior)
  --rate HZ               loop rate, 1..100000 (default 1000; tested 500..10000)
Placing a force device on the patient (usb-haptic; spacemouse takes --home and
--home-clearance; sim, replay and remote move in the scene frame and take none):
  --home SITE             where the device's workspace centre sits: auto (default: the
                          patient's anterior skin), anterior, left, right, ..., ribs-right,
                          ribs-left (middle of the ribs path), or X,Y,Z in patient coordinates
                          (the CT's LPS world, mm)
  --home-clearance MM     the home point is this far above the skin along its normal (20)
  --device-axes XYZ       the patient directions of the device's x, y, z (default IAR: y up =
                          anterior, z toward the user = the patient's right, x = inferior)
  --device-scale S        scene mm per device mm (default 1)
  --workspace-mm MM       the device's workspace, +-MM about its centre (default 50; a
                          Falcon is about +-50, a Touch about +-80 x 60 x 35)
palpd refuses to start when the device, so placed, cannot reach 10 mm below the skin.
  --port P                TCP port (default 7400; 0 = any free port, printed at start)
  --bind ADDR             address to listen on (default 127.0.0.1; 0.0.0.0 for a lab network)
  --token TOKEN           CONTROLLER clients must present it (prefer the config file); never
                          accepted in plain text from beyond loopback
  --tls-cert FILE         palp.v1 over TLS 1.3 only, with this PEM certificate (and chain) ...
  --tls-key FILE          ... and its key (mode 600); plain-text clients are refused
  --tls-client-ca FILE    controllers must present a client certificate signed by this CA (its
                          subject names them in Stats, logs and recordings; observers may)
  --tls-controllers FILE  only these certificate subjects may be the controller, one per line
                          as `openssl x509 -noout -subject -nameopt RFC2253` prints them;
                          other certificates from the CA may observe (docs/security.md)
  --max-clients N         default 16 (1..1024)
  --queue N               haptic frames queued per client before the oldest is dropped
                          (256; 1..65536)
  --queue-bytes N         everything queued for one client (frames, pongs, errors, results),
                          each message counted with 128 bytes more; a client past it that still
                          does not read is dropped (4194304; 65536..1073741824)
  --idle-timeout S        close clients that send nothing (Ping) for S s (30; 0 = never;
                          at most 86400)
  --hello-timeout S       close clients that send no Hello within S s (5; 0.1..600)
  --write-timeout S       close clients whose socket accepts nothing for S s (5; 0 = never;
                          at most 600)
  --poll-us US            --net-wake poll: how often the network thread takes new frames
                          (500; 50..100000)
  --record FILE           record every tick into FILE (binary, see server/rt/recording.hpp) and a
                          CSV beside it: FILE with its extension replaced by .csv (rec/s1.palprec
                          -> rec/s1.csv; no extension: rec/s1 -> rec/s1.csv); either one existing
                          is refused, never written over
  --record-dir DIR        where StartRecording commands (palp ctl record start) write, made at
                          start when missing (default: the current directory)
  --watchdog-ms MS        a tick starting MS later than its deadline zeroes the force (5; 0 off;
                          at most 1000)
  --device-timeout-ms MS  a device silent for MS zeroes the force (100; 0 = off; at most 10000)
  --priority N            SCHED_FIFO priority of the loop thread (80)
  --no-realtime           do not ask for SCHED_FIFO and locked memory
  --duration S            stop after S seconds (default: until SIGINT / SIGTERM)
  --stats-json FILE       at exit, write the loop's and the server's counters as JSON (ticks,
                          overruns, lateness histogram and percentile bounds, frames sent)
  --config FILE           TOML file with any of these options as keys (scene = "phantom:torso",
                          rate = 1000, no-realtime = true, param = ["c=2.0"], ...)
  -q, --quiet             print only warnings and errors
  -h, --help              show this help
)";

const std::vector<std::string> kFlags = cli::with_dds_flags(
    {"help", "quiet", "no-realtime", "no-force-limits", "allow-truncated", "tune"});
const std::vector<std::string> kValued = {"device",
                                          "tool",
                                          "device-profile",
                                          "rate",
                                          "port",
                                          "bind",
                                          "token",
                                          "max-clients",
                                          "queue",
                                          "idle-timeout",
                                          "hello-timeout",
                                          "write-timeout",
                                          "record",
                                          "record-dir",
                                          "watchdog-ms",
                                          "device-timeout-ms",
                                          "priority",
                                          "duration",
                                          "config",
                                          "poll-us",
                                          "stats-json",
                                          "device-axes",
                                          "device-scale",
                                          "home",
                                          "engage-ramp-s",
                                          "home-clearance",
                                          "workspace-mm",
                                          "queue-bytes",
                                          "falcon-firmware",
                                          "falcon-tool-from",
                                          "tls-cert",
                                          "tls-key",
                                          "tls-client-ca",
                                          "tls-controllers",
                                          "tune-budget-s",
                                          "map-window"};
const std::vector<std::string> kValuedAll =
    interop::with_igtl_options(cli::with_dds_options(kValued));

double positive(const cli::Args& args, const std::string& key, double fallback) {
  const double v = args.number(key, fallback);
  if (v < 0) throw UsageError("--" + key + " must not be negative");
  return v;
}

// A number within [lo, hi], refused with the option's name and its range otherwise: no timeout
// or interval can overflow a clock, no queue be sized by a typo.
double within(const cli::Args& args, const std::string& key, double fallback, double lo,
              double hi) {
  const double v = args.number(key, fallback);
  if (!(v >= lo && v <= hi)) {
    char range[96];
    std::snprintf(range, sizeof range, " must be in [%g, %g]", lo, hi);
    throw UsageError("--" + key + range);
  }
  return v;
}

// palpd with its arguments: the config file's first, then the command line's (which win).
int run_configured(cli::Arguments argv);

int run(const cli::Arguments& argv_in) {
  // --help whatever the config file holds (it is the first thing to reach for when it is wrong)
  for (const std::string& a : argv_in)
    if (a == "--help" || a == "-h") {
      std::cout << kUsage << cli::kSceneOptionsHelp << kOptions << cli::kTuneAtStartHelp
                << cli::kMapWindowHelp << cli::kRtOptionsHelp << interop::kIgtlOptionsHelp
                << cli::kDdsOptionsHelp;
      return 0;
    }
  const auto config = cli::config_path(argv_in);
  std::map<std::string, int> lines;
  cli::Arguments from_config;
  if (config)
    from_config = cli::config_arguments(*config, kFlags, cli::with_rt_options(kValuedAll), &lines);
  try {
    from_config.insert(from_config.end(), argv_in.begin(), argv_in.end());
    return run_configured(std::move(from_config));
  } catch (const UsageError& e) {
    if (!config) throw;
    throw UsageError(cli::config_error(e.what(), *config, lines, argv_in));
  }
}

int run_configured(cli::Arguments argv) {
  argv = palp::dds::split_dds_domain(std::move(argv));  // --dds [DOMAIN]
  const std::vector<std::string> assignments = cli::take_repeated(argv, "param");
  std::vector<std::string> valued = cli::kSceneOptions;
  valued = cli::with_rt_options(std::move(valued));
  valued.insert(valued.end(), kValuedAll.begin(), kValuedAll.end());
  cli::Args args(argv, kFlags, valued);
  if (args.has("help")) {
    std::cout << kUsage << cli::kSceneOptionsHelp << kOptions << cli::kTuneAtStartHelp
              << cli::kMapWindowHelp << cli::kRtOptionsHelp << interop::kIgtlOptionsHelp
              << cli::kDdsOptionsHelp;
    return 0;
  }
  if (!args.positional().empty())
    throw UsageError("palpd takes no positional arguments, got '" + args.positional()[0] + "'");
  const auto device_spec = args.get("device");
  if (!device_spec)
    throw UsageError(
        "palpd needs --device DEVICE (sim, sim:FILE, replay:FILE, remote, usb-haptic[:VID:PID])");
  const bool quiet = args.has("quiet");

  // A replay brings its own scene, tool, rate, profile and parameters unless given.
  std::optional<rt::Recording> replay;
  std::vector<std::string> params_in = assignments;
  std::vector<std::string> defaults;
  if (device_spec->rfind("replay:", 0) == 0) {
    replay = rt::read_recording(device_spec->substr(7));
    if (replay->truncated) {
      const std::string what =
          device_spec->substr(7) + " ends inside a record (cut short, e.g. by a crash): " +
          std::to_string(replay->records.size()) + " whole ticks" +
          (replay->records.empty()
               ? std::string()
               : ", the last seq " + std::to_string(replay->records.back().seq));
      if (!args.has("allow-truncated"))
        throw InputError(what + "; pass --allow-truncated to replay them");
      std::fprintf(stderr, "palpd: warning: %s\n", what.c_str());
    }
    const auto meta = [&](const std::string& key) -> std::optional<std::string> {
      const auto it = replay->metadata.find(key);
      if (it == replay->metadata.end() || it->second.empty()) return std::nullopt;
      return it->second;
    };
    for (const char* key : {"scene", "tool", "rate", "device-profile", "scheme", "storage"})
      if (!args.has(key))
        if (const auto v = meta(key)) defaults.push_back("--" + std::string(key) + "=" + *v);
    std::vector<std::string> recorded_params;
    // recordings made before the palp model was added ran the paper's
    if (!meta("param.model")) recorded_params.push_back("model=0");
    for (const auto& [key, value] : replay->metadata)
      if (key.rfind("param.", 0) == 0) recorded_params.push_back(key.substr(6) + "=" + value);
    params_in.insert(params_in.begin(), recorded_params.begin(), recorded_params.end());
  }
  if (!defaults.empty()) {
    defaults.insert(defaults.end(), argv.begin(), argv.end());
    args = cli::Args(defaults, kFlags, valued);
  }

  Tool tool = parse_tool(args.get("tool").value_or("finger:37"));
  const ForceParams params = cli::force_params(cli::model_kind(args), tool, params_in);
  const DeviceProfile* profile = nullptr;
  if (const auto name = args.get("device-profile")) profile = &device_profile(*name);
  rt::LoopConfig loop_config;
  loop_config.rate_hz = args.number("rate", 1000.0);
  if (!(loop_config.rate_hz >= 1.0 && loop_config.rate_hz <= 100000.0))
    throw UsageError("--rate must be between 1 and 100000 Hz");
  loop_config.realtime = !args.has("no-realtime");
  loop_config.priority = static_cast<int>(args.number("priority", 80));
  loop_config.watchdog_late_s = within(args, "watchdog-ms", 5.0, 0, 1000) * 1e-3;
  loop_config.device_timeout_s = within(args, "device-timeout-ms", 100.0, 0, 10000) * 1e-3;
  net::ServerConfig server_config;
  server_config.bind = args.get("bind").value_or("127.0.0.1");
  const double port = args.number("port", 7400);
  if (port < 0 || port > 65535 || port != std::floor(port))
    throw UsageError("--port must be an integer in 0..65535");
  server_config.port = static_cast<std::uint16_t>(port);
  server_config.token = args.get("token").value_or("");
  (void)cli::dds_config_from(args, loop_config.rate_hz);  // its refusals before TLS loads
  server_config.tls = cli::server_tls(args);
  server_config.max_clients = static_cast<std::size_t>(within(args, "max-clients", 16, 1, 1024));
  server_config.queue_frames =
      std::max<std::size_t>(1, static_cast<std::size_t>(within(args, "queue", 256, 1, 65536)));
  server_config.max_queue_bytes =
      static_cast<std::size_t>(within(args, "queue-bytes", 4 << 20, 64 << 10, 1 << 30));
  server_config.idle_timeout_s = within(args, "idle-timeout", 30, 0, 86400);
  server_config.hello_timeout_s = within(args, "hello-timeout", 5, 0.1, 600);
  server_config.write_timeout_s = within(args, "write-timeout", 5, 0, 600);
  server_config.poll_interval_s = within(args, "poll-us", 500, 50, 100000) * 1e-6;
  cli::apply_rt_options(args, loop_config, server_config);
  const double duration = within(args, "duration", 0, 0, 1e7);
  const std::string record_dir = args.get("record-dir").value_or(".");
  {
    // made now, so a StartRecording is not refused an hour into a study for a missing folder
    std::error_code ec;
    std::filesystem::create_directories(record_dir, ec);
    if (ec || !std::filesystem::is_directory(record_dir))
      throw UsageError("--record-dir " + record_dir + ": not a directory palpd can create" +
                       (ec ? " (" + ec.message() + ")" : std::string()));
  }
  const std::string stats_json = args.get("stats-json").value_or("");
  (void)cli::scene_options(args);

  std::unique_ptr<rt::Device> device =
      replay ? std::make_unique<rt::ReplayDevice>(std::move(replay->records))
             : rt::make_device(*device_spec);
  cli::prepare_falcon(args, *device);  // the firmware file, before anything is awaited
  // Limits: a device that pushes on a hand always gets them (the profile, or the most
  // conservative class), lowered in the loop to what the device declares; engagement with them.
  const bool drives_a_hand = device->kind() == "usb-haptic" || device->kind() == "falcon";
  if (drives_a_hand && !profile) {
    if (args.has("no-force-limits")) {
      std::fprintf(stderr,
                   "palpd: WARNING: --no-force-limits: the model's raw force goes to the device, "
                   "unclamped and unramped (the skin law alone reaches 144 N at 20 mm). Keep "
                   "hands off the device.\n");
    } else {
      profile = device->kind() == "falcon" ? &device_profile("falcon") : &default_device_profile();
      if (!quiet)
        std::fprintf(stderr,
                     "palpd: no --device-profile: limiting the force to the %s class (%.1f N, "
                     "%.1f N/mm) and to what the device declares\n",
                     std::string(profile->name).c_str(), profile->max_force_N,
                     profile->max_stiffness_N_per_mm);
    }
  } else if (args.has("no-force-limits")) {
    throw UsageError("--no-force-limits applies to falcon and usb-haptic only");
  }
  loop_config.profile = profile;
  if (profile) {
    EngageParams engage;
    engage.ramp_s = args.number("engage-ramp-s", engage.ramp_s);
    validate(engage);
    loop_config.engage = engage;
    loop_config.passivity = true;
  }
  // the port first: a port in use is told before minutes of scene preparation
  net::check_listen_address(server_config.bind, server_config.port);
  Scene scene = cli::load_scene_for(args, "palpd", quiet);
  const auto tuning = cli::tune_at_start(args, scene, tool, params, loop_config.rate_hz, quiet);
  auto model = std::make_shared<const Model>(scene.fields, tool, params);

  rt::DeviceConfig device_config;
  device_config.rate_hz = loop_config.rate_hz;
  device_config.fields = scene.fields;
  device_config.tool = tool;
  device_config.timeout_s = std::max(loop_config.device_timeout_s, 0.01);
  // device frame -> scene: the registration of a device placed on the patient
  const std::optional<net::SceneDescription::Placement> placement =
      cli::place_device(args, device->kind(), scene, quiet);
  if (placement) loop_config.registration = placement->registration;
  cli::orient_falcon(args, *device, scene, placement);
  if (device->kind() == "spacemouse" && (args.get("home") || args.get("home-clearance"))) {
    const HomeSite site = find_home_site(*scene.fields, args.get("home").value_or("auto"),
                                         positive(args, "home-clearance", 20.0));
    Pose home;
    home.position = site.home;
    home.orientation =
        surface_orientation(site.normal, patient_frame(scene.grid).toward(Anatomy::Superior));
    device_config.home = home;
  }
  if (device->configure(device_config) != rt::DeviceStatus::Ok)
    throw InputError("device " + *device_spec + ": " + device->last_error());
  if (device->activate() != rt::DeviceStatus::Ok)
    throw InputError("device " + *device_spec + ": " + device->last_error());
  auto maps = cli::maps_at_start(args, *device_spec, device->kind(), scene, placement, tool, quiet);
  if (maps.windowed) model = std::make_shared<const Model>(maps.haptic, tool, params);
  device_config.fields.reset();  // the whole maps' gradient fields go with the last holder

  // Signals are taken by sigtimedwait below, in this thread only: block them before any thread.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  std::signal(SIGPIPE, SIG_IGN);

  rt::HapticLoop loop(model, *device, loop_config);
  rt::RecordingMetadata metadata = {
      {"scene", *args.get("scene")},
      {"rate", number_text(loop_config.rate_hz)},
      {"device", *device_spec},
      {"device-profile", profile ? std::string(profile->name) : ""},
      {"scheme", to_string(maps.haptic->config().gradient)},
      {"storage", to_string(maps.haptic->config().storage)},
      {"palp_version", PALP_VERSION},
  };
  cli::PalpdControl app(loop, maps.haptic, *device, metadata, record_dir);
  net::SceneDescription description;
  description.source = *args.get("scene");
  description.grid = scene.grid;
  description.metadata = {{"prep_dir", scene.prep_dir},
                          {"scheme", to_string(maps.haptic->config().gradient)},
                          {"storage", to_string(maps.haptic->config().storage)},
                          {"tuning", tuning.choice},
                          {"tuning_note", tuning.note},
                          {"maps", maps.note}};
  description.device = *device_spec;
  description.device_profile = profile ? std::string(profile->name) : "";
  description.fields = scene.fields;
  description.ct = scene.ct;
  description.body = scene.body;
  description.placement = placement;
  cli::DdsControlGate control(app);  // palp.v1's and DDS's device poses, one at a time
  net::Server server(server_config, description, loop, &control);
  const auto igtl = interop::igtl_beside(args, scene.grid, loop_config.rate_hz, server, quiet);
  const auto dds = cli::dds_beside(args, description, loop, control, server, tool.name, quiet);

  if (const auto record = args.get("record")) {
    const std::string failure = app.start(*record, "palpd --record");
    if (!failure.empty()) throw Error(failure);
  }
  loop.start();
  server.start();
  if (!loop.realtime_report().empty() &&
      (!quiet || loop.realtime_report().rfind("warning", 0) == 0))
    std::fprintf(stderr, "palpd: %s\n", loop.realtime_report().c_str());
  if (!quiet) {
    std::printf("palpd: listening on %s:%u, device %s, tool %s, %.6g Hz%s\n",
                server_config.bind.c_str(), static_cast<unsigned>(server.port()),
                device_spec->c_str(), tool.name.c_str(), loop_config.rate_hz,
                profile ? (std::string(", profile ") + std::string(profile->name)).c_str() : "");
    const PatientFrame frame = patient_frame(scene.grid);
    for (const std::string& line :
         cli::server_tls_report(server_config.tls.get(), server_config.bind))
      std::fprintf(line.rfind("warning", 0) == 0 ? stderr : stdout, "palpd: %s\n", line.c_str());
    if (server_config.token.empty() && !net::is_loopback_address(server_config.bind))
      std::printf(
          "palpd: WARNING: listening beyond this machine without --token: anyone who can "
          "reach %s:%u may become the controller (set 'token' in the config)\n",
          server_config.bind.c_str(), static_cast<unsigned>(server.port()));
    std::printf("palpd: patient stored %s: anterior is %s in the scene frame\n",
                frame.orientation_code().c_str(),
                to_string(frame.nearest_axis(Anatomy::Anterior)).c_str());
    std::fflush(stdout);
  }

  const std::int64_t start_ns = rt::monotonic_ns();
  int exit_signal = 0;
  // Hot-plug devices come and go: say so once per change (with the device's own words, e.g. the
  // udev rule to install), not once per tick.
  std::string device_report;
  while (!loop.finished()) {
    const std::string report = std::string("device ") + rt::to_string(loop.device_state()) + ": " +
                               device->status_message();
    if (report != device_report && !device->status_message().empty()) {
      device_report = report;
      if (!quiet || loop.device_state() == rt::DeviceState::Fault)
        std::fprintf(stderr, "palpd: %s\n", report.c_str());
    }
    cli::warn_if_home_left_window(maps, loop.registration_home());
    timespec wait{0, 100'000'000};
    const int sig = sigtimedwait(&signals, nullptr, &wait);
    if (sig == SIGINT || sig == SIGTERM) {
      exit_signal = sig;
      break;
    }
    if (duration > 0 && static_cast<double>(rt::monotonic_ns() - start_ns) * 1e-9 >= duration)
      break;
  }
  if (loop.finished()) {
    // Let the network thread pass on the last frames before it stops.
    timespec pause{0, 50'000'000};
    nanosleep(&pause, nullptr);
  }
  server.stop();
  loop.stop();  // the device gets zero force
  if (app.recording()) app.stop_recording();
  device->deactivate();

  const rt::LoopStats s = loop.stats();
  const net::ServerCounters c = server.counters();
  if (!stats_json.empty())
    cli::write_stats_json(stats_json, s, c, loop_config.rate_hz,
                          static_cast<double>(rt::monotonic_ns() - start_ns) * 1e-9);
  if (!quiet) {
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
  return 0;
}

}  // namespace
}  // namespace palp

int main(int argc, char** argv) {
  try {
    return palp::run(palp::cli::Arguments(argv + 1, argv + argc));
  } catch (const palp::UsageError& e) {
    std::fprintf(stderr, "palpd: %s\n", e.what());
    return 2;
  } catch (const palp::Error& e) {
    std::fprintf(stderr, "palpd: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palpd: error: %s\n", e.what());
    return 1;
  }
}
