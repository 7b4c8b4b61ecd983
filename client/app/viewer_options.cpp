// palpview's command line: see viewer_options.hpp.
#include "app/viewer_options.hpp"

#include <cctype>
#include <cmath>
#include <exception>
#include <stdexcept>
#include <string>

#include "base/errors.hpp"
#include "client_core/host_port.hpp"
#include "dds_common.hpp"
#include "stream/stream_client.hpp"
#include "tls/client_policy.hpp"

namespace palp::view {

const char* const kUsage = R"(usage: palpview --connect HOST:PORT [options]

The render client: connects to palpd, shows the volume, the tool, contacts, proxies and force,
and deforms the skin where the tool presses.

  --connect HOST:PORT     palpd's address (or --dds)
  --dds [DOMAIN]          watch a palpd --dds on DDS domain DOMAIN (0) instead (observer only;
                          docs/dds.md)
  --rig NAME              with --dds: which rig (default: the host name, as palpd's)
  --observer              only watch (default); the mouse moves this view's camera
  --controller            drive palpd's `remote` device (palpd --device remote) with mouse
                          and keyboard
  --token T               the server's controller token, sent only over TLS or loopback:
                          palpview refuses to connect to another machine with it and without
                          --tls-ca/--tls-pin
  --tls-ca FILE           palp.v1 over TLS: check palpd's certificate against this CA and the
                          host name of --connect
  --tls-pin SHA256        or: trust exactly the palpd certificate with this SHA-256 fingerprint
  --tls-cert FILE         this station's certificate (palpd --tls-client-ca asks controllers)
  --tls-key FILE          its key (mode 600)
  --name NAME             client name shown by the server (default palpview)
  --rate HZ               frames/s asked of the server (default 120)
  --volume-max-dim N      render volume: at most N voxels per axis (default 256)
  --preset skin|bone|soft|vessels
                          transfer-function preset (default skin), on the CT's HU; vessels:
                          the body a faint veil under the scene's structures (palpd's prep
                          directory: vessel.nii.gz, artery.nii.gz, organs), each in its own
                          colour, named in a legend, the artery beating with the pulse
  --show-outside          show the CT outside the body mask (table, cables; default hidden,
                          and the volume cropped to the body's box)
  --no-ct                 render the distance maps' pseudo-density, not the CT's HU
  --skin-hu               the skin preset on the CT's HU (3 mm terraces on a 3 mm CT) instead
                          of the sub-voxel skin, d_surf's zero level (docs/palpview.md)
  --no-deformation        do not deform the skin
  --width W --height H    window size (default 1280x800)
  --view SIDE             the camera's starting view: the patient's anterior (default),
                          posterior, left, right, superior or inferior, taken from the CT's
                          direction matrix (not the voxel order)
  --camera AZ,EL,DIST     camera azimuth and elevation (degrees) from that view and
                          distance (mm, 0 = fit), about the volume's centre (no --follow)
  --follow MM             look at the tool obliquely, between that view and the tool's
                          axis, MM of anatomy across the view's height, and follow it
                          smoothly (default 150 without --camera; 0 = off)
  --chart-seconds S       the force chart's span: the last S seconds of this session
                          (default 30, 1 .. 600)
  --no-orientation-marker hide the patient-axes cube (bottom left)
  --no-overlays           hide the HUD, the chart and the orientation marker
  --no-tool               hide the tool, contacts, proxies, springs, arrow and shadow
  --show-landmarks        show the scan's landmarks from the start, as key L does (palpd
                          --landmarks sends them to observers; never to the controller while
                          a training task runs)
  --screenshot FILE       render --frames N frames from the live stream, write a PNG, exit
  --frames N              frames before the screenshot (default 5)
  --timeout S             how long --screenshot waits for the scene (default 60)
  --script FILE           controller: send the poses of a trajectory CSV
                          (t,px,py,pz,qw,qx,qy,qz; t from the first live frame), then hold
                          the last one
  --stats-json FILE       write the frame-time split (receive/deformation/render) as JSON
  --duration S            exit after S seconds
  -h, --help              this text

Mouse: left drag orbits (controller: slides the tool; shift: rotates it), middle drag orbits,
right drag windows (x: level, y: width), scroll zooms (controller: presses; ctrl: zooms).
Keys: P next preset, [ ] level, - = width, V next view (anterior, left, posterior, right,
superior, inferior), L the scan's landmarks (palpd --landmarks; never shown to the controller
while a training task runs), Home camera reset, Esc quit; controller: M marks a training task's
spot (palpd scores it), H re-centres a device placed on
the patient (palpd --home), arrows
slide, W/S press, Q/E R/F Z/C rotate, 1/2/3 finger:37/twofinger:19/probe:9x3, space pause,
O start / stop a recording (trial-YYYYMMDD-HHMMSS in palpd's --record-dir), , and . the
arteries' heart rate down / up 6 bpm, B the pulse off / on, backspace start pose. The HUD shows
RECORDING and PAUSED, the pulse's rate, palpd's answer to the last command, and the training
task, its trial and marks (observers: the last mark's score).
)";

namespace {

double parse_number(const std::string& option, const std::string& text) {
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    if (used != text.size() || !std::isfinite(v)) throw std::invalid_argument(text);
    return v;
  } catch (const std::exception&) {
    throw UsageError(option + ": not a number: '" + text + "'");
  }
}

int parse_int(const std::string& option, const std::string& text, int lo, int hi) {
  const double v = parse_number(option, text);
  if (v != std::floor(v) || v < lo || v > hi)
    throw UsageError(option + ": expected an integer from " + std::to_string(lo) + " to " +
                     std::to_string(hi) + ", got '" + text + "'");
  return static_cast<int>(v);
}

// The command line, one option at a time: n is the option being read.
struct ArgCursor {
  int argc;
  char** argv;
  int n;
  // The option's value (the next argument); UsageError when there is none.
  std::string value(const std::string& option) {
    if (n + 1 >= argc) throw UsageError(option + " needs a value");
    return argv[++n];
  }
};

// What the options said that only the checks after them need.
struct Seen {
  bool connect = false, frames = false;
  std::optional<std::string> rig;
};

// --camera AZ,EL,DIST.
void parse_camera(const std::string& arg, const std::string& text, Options& o) {
  const auto c1 = text.find(','), c2 = text.find(',', c1 == std::string::npos ? 0 : c1 + 1);
  if (c1 == std::string::npos || c2 == std::string::npos)
    throw UsageError("--camera: expected AZ,EL,DIST, got '" + text + "'");
  o.az = parse_number(arg, text.substr(0, c1));
  o.el = parse_number(arg, text.substr(c1 + 1, c2 - c1 - 1));
  o.dist = parse_number(arg, text.substr(c2 + 1));
  if (o.dist < 0) throw UsageError("--camera: the distance must be >= 0");
  o.have_camera = true;
}

// The options that reach the server (palp.v1 or DDS) and say who palpview is; false: not one.
bool connection_option(const std::string& arg, ArgCursor& in, Options& o, Seen& seen) {
  if (arg == "--connect") {
    client::parse_host_port(in.value(arg), o.host, o.port);
    seen.connect = true;
  } else if (arg == "--dds") {  // [DOMAIN]
    o.dds = true;
    if (in.n + 1 < in.argc && std::isdigit(static_cast<unsigned char>(in.argv[in.n + 1][0])))
      o.dds_domain = palp::dds::parse_domain(in.argv[++in.n]);
  } else if (arg == "--rig") {
    seen.rig = in.value(arg);
  } else if (arg == "--observer") {
    o.controller = false;
  } else if (arg == "--controller") {
    o.controller = true;
  } else if (arg == "--token") {
    o.token = in.value(arg);
  } else if (arg == "--tls-ca") {
    o.tls_ca = in.value(arg);
  } else if (arg == "--tls-pin") {
    o.tls_pin = in.value(arg);
  } else if (arg == "--tls-cert") {
    o.tls_cert = in.value(arg);
  } else if (arg == "--tls-key") {
    o.tls_key = in.value(arg);
  } else if (arg == "--name") {
    o.name = in.value(arg);
  } else if (arg == "--rate") {
    o.rate_hz = parse_number(arg, in.value(arg));
    if (o.rate_hz < 0 || o.rate_hz > 100000) throw UsageError("--rate: 0 to 100000 Hz");
  } else if (arg == "--volume-max-dim") {
    o.volume_max_dim = static_cast<std::uint32_t>(parse_int(arg, in.value(arg), 0, 4096));
  } else {
    return false;
  }
  return true;
}

// The options that choose what the window shows and from where; false: not one.
bool view_option(const std::string& arg, ArgCursor& in, Options& o) {
  if (arg == "--preset") {
    o.preset = parse_preset(in.value(arg));
  } else if (arg == "--no-deformation") {
    o.deformation = false;
  } else if (arg == "--chart-seconds") {
    o.chart_s = parse_number(arg, in.value(arg));
    if (!(o.chart_s >= 1 && o.chart_s <= 600)) throw UsageError("--chart-seconds: 1 .. 600");
  } else if (arg == "--show-outside") {
    o.show_outside = true;
  } else if (arg == "--no-ct") {
    o.ct = false;
  } else if (arg == "--skin-hu") {
    o.skin_hu = true;
  } else if (arg == "--follow") {
    o.follow_mm = parse_number(arg, in.value(arg));
    if (!(o.follow_mm >= 0 && o.follow_mm <= 10000)) throw UsageError("--follow: 0 .. 10000 mm");
  } else if (arg == "--width") {
    o.width = parse_int(arg, in.value(arg), 64, 8192);
  } else if (arg == "--height") {
    o.height = parse_int(arg, in.value(arg), 64, 8192);
  } else if (arg == "--view") {
    const std::string text = in.value(arg);
    if (!parse_anatomy(text, &o.view))
      throw UsageError("--view: anterior, posterior, left, right, superior or inferior, got '" +
                       text + "'");
  } else if (arg == "--no-orientation-marker") {
    o.orientation_marker = false;
  } else if (arg == "--no-overlays") {
    o.overlays = false;
  } else if (arg == "--no-tool") {
    o.tool_glyphs = false;
  } else if (arg == "--show-landmarks") {
    o.show_landmarks = true;
  } else if (arg == "--camera") {
    parse_camera(arg, in.value(arg), o);
  } else {
    return false;
  }
  return true;
}

// The options of a run without a person: screenshots, scripts, limits, stats; false: not one.
bool run_option(const std::string& arg, ArgCursor& in, Options& o, Seen& seen) {
  if (arg == "--screenshot") {
    o.screenshot = in.value(arg);
  } else if (arg == "--frames") {
    o.frames = parse_int(arg, in.value(arg), 1, 1000000);
    seen.frames = true;
  } else if (arg == "--timeout") {
    o.timeout_s = parse_number(arg, in.value(arg));
    if (o.timeout_s <= 0) throw UsageError("--timeout: must be > 0");
  } else if (arg == "--script") {
    o.script = in.value(arg);
  } else if (arg == "--stats-json") {
    o.stats_json = in.value(arg);
  } else if (arg == "--duration") {
    o.duration_s = parse_number(arg, in.value(arg));
    if (o.duration_s <= 0) throw UsageError("--duration: must be > 0");
  } else {
    return false;
  }
  return true;
}

// The checks between options, and the defaults that depend on others.
void check_options(Options& o, const Seen& seen) {
  if (!seen.connect && !o.dds) throw UsageError("--connect HOST:PORT is required (or --dds)");
  if (seen.connect && o.dds) throw UsageError("--connect and --dds: one or the other");
  if (seen.rig && !o.dds) throw UsageError("--rig needs --dds");
  if (o.dds) palp::dds::check_rig(o.dds_rig = seen.rig.value_or(palp::dds::default_rig()));
  if (seen.frames && o.screenshot.empty()) throw UsageError("--frames needs --screenshot FILE");
  if (o.follow_mm < 0) o.follow_mm = o.have_camera ? 0.0 : 150.0;
  if (!o.script.empty() && !o.controller) throw UsageError("--script needs --controller");
  // a certificate without --tls-ca/--tls-pin would mean plain text (tls/client_policy.hpp)
  palp::tls::check_client_options({o.tls_ca, o.tls_pin, o.tls_cert, o.tls_key});
}

}  // namespace

// Returns nullopt for --help.
std::optional<Options> parse_options(int argc, char** argv) {
  Options o;
  Seen seen;
  ArgCursor in{argc, argv, 1};
  for (; in.n < argc; ++in.n) {
    const std::string arg = argv[in.n];
    if (arg == "-h" || arg == "--help") return std::nullopt;
    if (!connection_option(arg, in, o, seen) && !view_option(arg, in, o) &&
        !run_option(arg, in, o, seen))
      throw UsageError("unknown option '" + arg + "'");
  }
  check_options(o, seen);
  return o;
}

}  // namespace palp::view
