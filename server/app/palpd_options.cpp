// palpd's command line: the help text and the options parsed and checked (see the header).
#include "app/palpd_options.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <system_error>

#include "app/dds_options.hpp"
#include "app/igtl_options.hpp"
#include "app/maps_at_start.hpp"
#include "app/rt_options.hpp"
#include "app/tune_at_start.hpp"
#include "base/errors.hpp"
#include "cli_common/model_setup.hpp"
#include "cli_common/tls_options.hpp"
#include "dds_common.hpp"

namespace palp::app {
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
  --pulse-bpm N           the arteries' heart rate, 0..240 beats per minute (default 72; 0 = no
                          pulse); a controller changes it while palpd runs (palp ctl HOST:PORT
                          pulse N, palpview's , and . keys), contacts kept
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
  --landmarks FILE        the scan's landmarks (palp landmarks --out FILE): training tasks score
                          against them, and observers may show them
  --task KIND             a training task from the start: ptcd, lumbar or femoral (a controller
                          starts, marks and stops tasks too: palp ctl HOST:PORT task ...);
                          without --landmarks they are found in the scene (palp landmarks)
  --task-side SIDE        ptcd, femoral: right (default) or left
  --task-space N          ptcd: the intercostal space below rib N (9: the 9th/10th; 1..11)
  --task-interspace NAME  lumbar: L3/L4 (default) or L4/L5
  --task-report-dir DIR   where each session's report goes when it ends (task stop, palpd's
                          exit; default: --record-dir)
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

const std::vector<std::string> kFlags = app::with_dds_flags(
    {"help", "quiet", "no-realtime", "no-force-limits", "allow-truncated", "tune"});
const std::vector<std::string> kValued = {"device",
                                          "tool",
                                          "device-profile",
                                          "rate",
                                          "pulse-bpm",
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
                                          "map-window",
                                          "landmarks",
                                          "task",
                                          "task-side",
                                          "task-space",
                                          "task-interspace",
                                          "task-report-dir"};
const std::vector<std::string> kValuedAll =
    app::with_igtl_options(app::with_dds_options(kValued));

// What a replay brings: the options not given (--scene=..., ...) and its parameters.
struct ReplayDefaults {
  std::vector<std::string> options, params;
};

// A replay brings its own scene, tool, rate, profile and parameters unless given: read it, and
// return the options it brings (empty when none) and its parameters (before the command line's).
ReplayDefaults read_replay(PalpdOptions& o) {
  o.replay = rt::read_recording(o.replay_path);
  const rt::Recording& replay = *o.replay;
  if (replay.truncated) {
    const std::string what =
        o.replay_path + " ends inside a record (cut short, e.g. by a crash): " +
        std::to_string(replay.records.size()) + " whole ticks" +
        (replay.records.empty() ? std::string()
                                : ", the last seq " + std::to_string(replay.records.back().seq));
    if (!o.args.has("allow-truncated"))
      throw InputError(what + "; pass --allow-truncated to replay them");
    std::fprintf(stderr, "palpd: warning: %s\n", what.c_str());
  }
  const auto meta = [&](const std::string& key) -> std::optional<std::string> {
    const auto it = replay.metadata.find(key);
    if (it == replay.metadata.end() || it->second.empty()) return std::nullopt;
    return it->second;
  };
  std::vector<std::string> defaults;
  for (const char* key :
       {"scene", "tool", "rate", "device-profile", "scheme", "storage", "pulse-bpm"})
    if (!o.args.has(key))
      if (const auto v = meta(key)) defaults.push_back("--" + std::string(key) + "=" + *v);
  std::vector<std::string> recorded_params;
  // recordings made before the palp model was added ran the paper's
  if (!meta("param.model")) recorded_params.push_back("model=0");
  for (const auto& [key, value] : replay.metadata)
    if (key.rfind("param.", 0) == 0) recorded_params.push_back(key.substr(6) + "=" + value);
  return {defaults, recorded_params};
}

rt::LoopConfig loop_config_from(const cli::Args& args) {
  rt::LoopConfig loop_config;
  loop_config.rate_hz = args.number("rate", 1000.0);
  if (!(loop_config.rate_hz >= 1.0 && loop_config.rate_hz <= 100000.0))
    throw UsageError("--rate must be between 1 and 100000 Hz");
  loop_config.realtime = !args.has("no-realtime");
  loop_config.priority = static_cast<int>(args.number("priority", 80));
  loop_config.watchdog_late_s = option_within(args, "watchdog-ms", 5.0, 0, 1000) * 1e-3;
  loop_config.device_timeout_s = option_within(args, "device-timeout-ms", 100.0, 0, 10000) * 1e-3;
  return loop_config;
}

net::ServerConfig server_config_from(const cli::Args& args, double rate_hz) {
  net::ServerConfig server_config;
  server_config.bind = args.get("bind").value_or("127.0.0.1");
  const double port = args.number("port", 7400);
  if (port < 0 || port > 65535 || port != std::floor(port))
    throw UsageError("--port must be an integer in 0..65535");
  server_config.port = static_cast<std::uint16_t>(port);
  server_config.token = args.get("token").value_or("");
  (void)app::dds_config_from(args, rate_hz);  // its refusals before TLS loads
  server_config.tls = cli::server_tls(args);
  server_config.max_clients =
      static_cast<std::size_t>(option_within(args, "max-clients", 16, 1, 1024));
  server_config.queue_frames = std::max<std::size_t>(
      1, static_cast<std::size_t>(option_within(args, "queue", 256, 1, 65536)));
  server_config.max_queue_bytes =
      static_cast<std::size_t>(option_within(args, "queue-bytes", 4 << 20, 64 << 10, 1 << 30));
  server_config.idle_timeout_s = option_within(args, "idle-timeout", 30, 0, 86400);
  server_config.hello_timeout_s = option_within(args, "hello-timeout", 5, 0.1, 600);
  server_config.write_timeout_s = option_within(args, "write-timeout", 5, 0, 600);
  server_config.poll_interval_s = option_within(args, "poll-us", 500, 50, 100000) * 1e-6;
  return server_config;
}

// Made now, so a StartRecording is not refused an hour into a study for a missing folder.
void make_record_dir(const std::string& record_dir) {
  std::error_code ec;
  std::filesystem::create_directories(record_dir, ec);
  if (ec || !std::filesystem::is_directory(record_dir))
    throw UsageError("--record-dir " + record_dir + ": not a directory palpd can create" +
                     (ec ? " (" + ec.message() + ")" : std::string()));
}

}  // namespace

std::string palpd_help() {
  return std::string(kUsage) + cli::kSceneOptionsHelp + kOptions + app::kTuneAtStartHelp +
         app::kMapWindowHelp + app::kRtOptionsHelp + app::kIgtlOptionsHelp +
         app::kDdsOptionsHelp;
}

const std::vector<std::string>& palpd_flags() {
  return kFlags;
}
const std::vector<std::string>& palpd_valued() {
  return kValuedAll;
}

double option_positive(const cli::Args& args, const std::string& key, double fallback) {
  const double v = args.number(key, fallback);
  if (v < 0) throw UsageError("--" + key + " must not be negative");
  return v;
}

double option_within(const cli::Args& args, const std::string& key, double fallback, double lo,
                     double hi) {
  const double v = args.number(key, fallback);
  if (!(v >= lo && v <= hi)) {
    char range[96];
    std::snprintf(range, sizeof range, " must be in [%g, %g]", lo, hi);
    throw UsageError("--" + key + range);
  }
  return v;
}

std::optional<PalpdOptions> parse_palpd_options(cli::Arguments argv) {
  argv = palp::dds::split_dds_domain(std::move(argv));  // --dds [DOMAIN]
  std::vector<std::string> params_in = cli::take_repeated(argv, "param");
  std::vector<std::string> valued = app::with_rt_options(cli::kSceneOptions);
  valued.insert(valued.end(), kValuedAll.begin(), kValuedAll.end());
  PalpdOptions o(cli::Args(argv, kFlags, valued));
  if (o.args.has("help")) return std::nullopt;
  if (!o.args.positional().empty())
    throw UsageError("palpd takes no positional arguments, got '" + o.args.positional()[0] + "'");
  const auto device_spec = o.args.get("device");
  if (!device_spec)
    throw UsageError(
        "palpd needs --device DEVICE (sim, sim:FILE, replay:FILE, remote, usb-haptic[:VID:PID])");
  o.device_spec = *device_spec;
  o.quiet = o.args.has("quiet");
  if (o.device_spec.rfind("replay:", 0) == 0) {
    o.replay_path = o.device_spec.substr(7);
    auto [defaults, recorded_params] = read_replay(o);
    params_in.insert(params_in.begin(), recorded_params.begin(), recorded_params.end());
    if (!defaults.empty()) {
      defaults.insert(defaults.end(), argv.begin(), argv.end());
      o.args = cli::Args(defaults, kFlags, valued);
    }
  }
  const cli::Args& args = o.args;
  o.tool = parse_tool(args.get("tool").value_or("finger:37"));
  o.params = cli::force_params(cli::model_kind(args), o.tool, params_in);
  o.params.pulse_bpm = option_within(args, "pulse-bpm", o.params.pulse_bpm, 0, rt::kMaxPulseBpm);
  if (const auto name = args.get("device-profile")) o.profile = &device_profile(*name);
  o.loop = loop_config_from(args);
  o.server = server_config_from(args, o.loop.rate_hz);
  app::apply_rt_options(args, o.loop, o.server);
  o.duration_s = option_within(args, "duration", 0, 0, 1e7);
  o.record_dir = args.get("record-dir").value_or(".");
  make_record_dir(o.record_dir);
  o.task = app::task_options(args, o.record_dir);
  o.stats_json = args.get("stats-json").value_or("");
  (void)cli::scene_options(args);
  return o;
}

}  // namespace palp::app
