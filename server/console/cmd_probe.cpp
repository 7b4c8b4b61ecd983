// palp probe HOST:PORT — a headless observer of palpd: connects, says Hello, receives frames for
// a while and reports frames per second, the delivered fraction, latency percentiles and the
// server's Stats. Exits non-zero when the stream stalls, the server sends a fatal Error or the
// connection fails. The last line of the output is JSON.
//
// Latency is (time received - the frame's server_time_ns), both CLOCK_MONOTONIC: meaningful only
// on the server's own host (a loopback address, or --same-host for another address of the same
// machine, e.g. across a network namespace); elsewhere it is reported as unavailable.
// server_time_ns is the tick's deadline, so the figure includes the tick itself, the loop's
// wake-up lateness, the network thread's polling interval and the socket.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "asio.hpp"
#include "base/device_state.hpp"
#include "base/errors.hpp"
#include "base/patient_frame.hpp"
#include "cli/commands.hpp"
#include "cli_common/cli.hpp"
#include "cli_common/tls_options.hpp"
#include "client_core/host_port.hpp"
#include "client_core/server_link.hpp"
#include "console/check_rate.hpp"
#include "console/json_number.hpp"
#include "console/probe_dds.hpp"
#include "loop/haptic_loop.hpp"
#include "wire/framing.hpp"
#include "wire/messages.hpp"

namespace palp::cli {
namespace {

constexpr const char* kProbeUsage = R"(usage: palp probe HOST:PORT [options]
       palp probe --check-rate HZ [--duration S] [options]

A headless palpd observer: prints frames/s, the delivered fraction, latency percentiles and the
server's stats, and exits non-zero (1) if the stream stalls or the server refuses the client.
Options:
  --duration S            how long to listen (default 5)
  --rate HZ               frames per second to ask for (default 0: every tick)
  --stall S               no frame for S seconds counts as a stall (default 1)
  --contacts              ask for per-contact data in every frame
  --same-host             the server shares this machine's clock though not reached on
                          loopback (another network namespace): report latency anyway
  --volume-max-dim N      ask for the render volume, at most N voxels along each axis
  --role ROLE             observer (default) or controller
  --token TOKEN           the server's token (controller); sent only over TLS or loopback:
                          to another machine without --tls-ca/--tls-pin probe refuses to connect
  --name NAME             client name (default palp-probe)
  --tls-ca FILE           palp.v1 over TLS: check the server's certificate against this CA and
                          the host name
  --tls-pin SHA256        or: trust exactly the server certificate with this SHA-256
                          fingerprint (openssl x509 -noout -fingerprint -sha256 -in CERT)
  --tls-cert FILE         this client's certificate (a controller, when palpd asks for one)
  --tls-key FILE          its key (mode 600)
  -q, --quiet             print only the JSON line
  -h, --help              show this help
)";

using asio::ip::tcp;

struct Report {
  std::uint64_t frames = 0;
  std::uint64_t first_seq = 0, last_seq = 0;
  std::int64_t first_rx_ns = 0, last_rx_ns = 0;
  std::int64_t first_t_ns = 0, last_t_ns = 0;
  std::uint64_t gaps = 0, gap_frames = 0, max_gap = 0;
  std::int64_t max_interval_ns = 0;  // longest time between two frames received
  std::uint64_t intervals_over_50ms = 0;
  std::uint64_t fault_frames = 0, contact_frames = 0;
  std::vector<double> latency_us;
  std::uint64_t volume_chunks = 0, volume_bytes = 0;
  std::uint64_t bytes = 0;
  std::uint64_t errors = 0;
  bool have_stats = false;
  v1::Stats stats;
  v1::SceneInfo scene;
  bool have_scene = false;
  std::string failure;  // non-empty: exit 1
  std::string welcome_server;
  double tick_rate_hz = 0.0;
};

double percentile_rounded_rank(std::vector<double>& v, double p) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(std::min<double>(
      static_cast<double>(v.size() - 1), std::floor(p * static_cast<double>(v.size() - 1) + 0.5)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

class Probe {
 public:
  Probe(std::string host, std::string port, v1::Hello hello, double duration_s, double stall_s,
        tls::ClientContext* tls)
      : host_(std::move(host)),
        port_(std::move(port)),
        hello_(std::move(hello)),
        duration_ns_(static_cast<std::int64_t>(duration_s * 1e9)),
        stall_ns_(static_cast<std::int64_t>(stall_s * 1e9)),
        tls_(tls),
        link_(io_, "the server",
              {[this](std::size_t n) { report_.bytes += n; },
               [this](const v1::ServerMessage& m) { handle(m); },
               [this](const std::string& why) { fail(why); }}),
        timer_(io_) {}

  Report run() {
    const auto endpoints =
        client::resolve_peer(io_, host_, port_, !hello_.token().empty(), tls_ != nullptr);
    start_ns_ = rt::monotonic_ns();
    tls::async_connect(link_.stream(), endpoints, host_, port_, tls_,
                       [this](const std::string& failure) {
                         if (!failure.empty()) return fail(failure);
                         asio::error_code e;
                         const tcp::endpoint endpoint = link_.stream().socket().remote_endpoint(e);
                         loopback_ = !e && endpoint.address().is_loopback();
                         v1::ClientMessage m;
                         *m.mutable_hello() = hello_;
                         send(m);
                         link_.read();
                       });
    tick();
    io_.run();
    return std::move(report_);
  }

  bool loopback() const { return loopback_; }

 private:
  void fail(const std::string& why) {
    if (report_.failure.empty()) report_.failure = why;
    finish();
  }
  void finish() {
    timer_.cancel();
    link_.close();
  }

  void send(const v1::ClientMessage& m) { link_.send(m); }

  void handle(const v1::ServerMessage& m) {
    const std::int64_t now = rt::monotonic_ns();
    switch (m.msg_case()) {
      case v1::ServerMessage::kWelcome:
        report_.welcome_server = m.welcome().server_name();
        report_.tick_rate_hz = m.welcome().tick_rate_hz();
        welcomed_ns_ = now;
        break;
      case v1::ServerMessage::kScene:
        report_.scene = m.scene();
        report_.have_scene = true;
        break;
      case v1::ServerMessage::kVolume:
        ++report_.volume_chunks;
        report_.volume_bytes += m.volume().d_surf().size() + m.volume().d_bone().size();
        break;
      case v1::ServerMessage::kFrame: {
        const v1::HapticFrame& f = m.frame();
        Report& r = report_;
        if (r.frames == 0) {
          r.first_seq = f.seq();
          r.first_rx_ns = now;
          r.first_t_ns = f.server_time_ns();
        } else if (f.seq() > r.last_seq + 1 && hello_.frame_rate_hz() == 0.0) {
          ++r.gaps;
          r.gap_frames += f.seq() - r.last_seq - 1;
          r.max_gap = std::max<std::uint64_t>(r.max_gap, f.seq() - r.last_seq - 1);
        }
        if (r.frames > 0) {
          r.max_interval_ns = std::max(r.max_interval_ns, now - r.last_rx_ns);
          if (now - r.last_rx_ns > 50'000'000) ++r.intervals_over_50ms;
        }
        ++r.frames;
        r.last_seq = f.seq();
        r.last_rx_ns = now;
        r.last_t_ns = f.server_time_ns();
        if (f.fault() != 0) ++r.fault_frames;
        if (f.n_contact() > 0) ++r.contact_frames;
        if (r.latency_us.size() < 2'000'000)
          r.latency_us.push_back(static_cast<double>(now - f.server_time_ns()) * 1e-3);
        break;
      }
      case v1::ServerMessage::kStats:
        report_.stats = m.stats();
        report_.have_stats = true;
        break;
      case v1::ServerMessage::kError:
        ++report_.errors;
        if (m.error().fatal()) {
          fail("server error: " + v1::Error::Code_Name(m.error().code()) + ": " +
               m.error().reason());
          return;
        }
        std::fprintf(stderr, "probe: server error: %s: %s\n",
                     v1::Error::Code_Name(m.error().code()).c_str(), m.error().reason().c_str());
        break;
      case v1::ServerMessage::kResult:
      case v1::ServerMessage::kPong:
      case v1::ServerMessage::kHistory:  // the force chart's, not the probe's
      case v1::ServerMessage::kTask:     // the training task: palp ctl task status
      case v1::ServerMessage::kLandmarks:
      case v1::ServerMessage::MSG_NOT_SET:
        break;
    }
  }

  // Every 50 ms: stall check, Ping once a second, the end of the run.
  void tick() {
    timer_.expires_after(std::chrono::milliseconds(50));
    timer_.async_wait([this](const asio::error_code& ec) {
      if (ec || link_.closed()) return;
      const std::int64_t now = rt::monotonic_ns();
      if (now - start_ns_ >= duration_ns_) {
        finish();
        return;
      }
      const std::int64_t since = report_.frames ? report_.last_rx_ns
                                 : welcomed_ns_ ? welcomed_ns_
                                                : start_ns_;
      // Before the first frame the scene and volume may take a while: allow 5 s more.
      const std::int64_t allowed = report_.frames ? stall_ns_ : stall_ns_ + 5'000'000'000;
      if (now - since > allowed) {
        fail(report_.frames ? "stream stalled: no frame for " +
                                  std::to_string(static_cast<double>(now - since) * 1e-9) + " s"
                            : "no frame received");
        return;
      }
      if (welcomed_ns_ && now - last_ping_ns_ >= 1'000'000'000) {
        last_ping_ns_ = now;
        v1::ClientMessage m;
        m.mutable_ping()->set_id(++ping_id_);
        m.mutable_ping()->set_client_time_ns(now);
        send(m);
      }
      tick();
    });
  }

  std::string host_, port_;
  v1::Hello hello_;
  std::int64_t duration_ns_, stall_ns_;
  asio::io_context io_;
  tls::ClientContext* tls_ = nullptr;
  client::ServerLink link_;
  asio::steady_timer timer_;
  Report report_;
  bool loopback_ = false;
  std::int64_t start_ns_ = 0, welcomed_ns_ = 0, last_ping_ns_ = 0;
  std::uint64_t ping_id_ = 0;
};

// The device state's name (base/device_state.hpp); the wire's own zero is "unspecified", and a
// number palp.v1 does not define "?".
const char* device_state_text(v1::DeviceState state) {
  if (state == v1::DEVICE_STATE_UNSPECIFIED) return "unspecified";
  const DeviceState known = wire::from_proto(state);
  return known == DeviceState::Unknown ? "?" : to_string(known);
}

// What the command line asks of one probe run: the server, how long, and the Hello to send.
struct ProbeRequest {
  std::string target, host;
  std::uint16_t port = 0;
  double duration = 5.0, rate = 0.0, stall = 1.0;
  bool quiet = false, same_host = false;
  v1::Hello hello;
};

// The probe's options read and checked, and the Hello they ask for.
ProbeRequest probe_request(const Args& args) {
  if (args.positional().size() != 1) throw UsageError("probe needs HOST:PORT (or --check-rate HZ)");
  ProbeRequest q;
  q.target = args.positional()[0];
  if (const std::string why = client::host_port_problem(q.target, q.host, q.port); !why.empty())
    throw UsageError("probe needs HOST:PORT, got '" + q.target + "': " + why);
  q.duration = args.number("duration", 5.0);
  q.rate = args.number("rate", 0.0);
  q.stall = args.number("stall", 1.0);
  const double max_dim = args.number("volume-max-dim", 0.0);
  if (!(q.duration > 0)) throw UsageError("--duration must be positive");
  if (q.rate < 0) throw UsageError("--rate must not be negative");
  if (!(q.stall > 0)) throw UsageError("--stall must be positive");
  if (max_dim < 0 || max_dim > 65535) throw UsageError("--volume-max-dim must be in 0..65535");
  const std::string role = args.get("role").value_or("observer");
  if (role != "observer" && role != "controller")
    throw UsageError("--role must be observer or controller");
  q.quiet = args.has("quiet");
  q.same_host = args.has("same-host");

  q.hello.set_protocol_version(wire::kProtocolVersion);
  q.hello.set_role(role == "controller" ? v1::CONTROLLER : v1::OBSERVER);
  q.hello.set_token(args.get("token").value_or(""));
  q.hello.set_client_name(args.get("name").value_or("palp-probe"));
  q.hello.set_frame_rate_hz(q.rate);
  q.hello.set_want_contacts(args.has("contacts"));
  q.hello.set_volume_max_dim(static_cast<std::uint32_t>(max_dim));
  return q;
}

// The run's figures: frames/s, the delivered fraction and latency percentiles (NaN if unknown).
struct ProbeFigures {
  double span_s = 0.0, fps = 0.0, delivered = 0.0;
  bool latency_ok = false;
  double p50 = NAN, p90 = NAN, p99 = NAN, p999 = NAN, lmax = NAN;
};

// The figures of a run asked at `rate` frames/s (0: every tick); latency only when `latency_ok`.
ProbeFigures summarize(Report& r, double rate, bool latency_ok) {
  ProbeFigures s;
  s.span_s = static_cast<double>(r.last_rx_ns - r.first_rx_ns) * 1e-9;
  s.fps = r.frames > 1 && s.span_s > 0 ? static_cast<double>(r.frames - 1) / s.span_s : 0.0;
  double expected = 0.0;
  if (r.frames > 0) {
    expected = rate > 0
                   ? std::floor(static_cast<double>(r.last_t_ns - r.first_t_ns) * 1e-9 * rate) + 1
                   : static_cast<double>(r.last_seq - r.first_seq + 1);
  }
  s.delivered = expected > 0 ? std::min(1.0, static_cast<double>(r.frames) / expected) : 0.0;
  s.latency_ok = latency_ok && !r.latency_us.empty();
  if (s.latency_ok) {
    s.p50 = percentile_rounded_rank(r.latency_us, 0.5);
    s.p90 = percentile_rounded_rank(r.latency_us, 0.9);
    s.p99 = percentile_rounded_rank(r.latency_us, 0.99);
    s.p999 = percentile_rounded_rank(r.latency_us, 0.999);
    s.lmax = *std::max_element(r.latency_us.begin(), r.latency_us.end());
  }
  return s;
}

// The scene line and the patient's orientation in the scene frame.
void print_scene(const Report& r) {
  if (!r.have_scene) return;
  std::printf("  scene     %s, tool %s, device %s, %.6g Hz\n", r.scene.source().c_str(),
              r.scene.tool().name().c_str(), r.scene.device().c_str(), r.scene.tick_rate_hz());
  if (r.scene.grid().direction_size() == 9) {
    WorldPlacement world;
    for (int i = 0; i < 9; ++i)
      world.direction[static_cast<std::size_t>(i)] = r.scene.grid().direction(i);
    const PatientFrame frame = patient_frame(world);
    std::printf("  patient   CT stored %s: anterior is %s, superior %s in the scene frame\n",
                frame.orientation_code().c_str(),
                to_string(frame.nearest_axis(Anatomy::Anterior)).c_str(),
                to_string(frame.nearest_axis(Anatomy::Superior)).c_str());
  }
}

// Where the device is placed on the patient, and how often it was re-centred.
void print_placement(const Report& r) {
  if (!r.have_scene) return;
  if (!r.scene.has_registration()) {
    std::printf("  device    moves in the scene frame (no registration)\n");
    return;
  }
  const v1::Registration& g = r.scene.registration();
  std::printf(
      "  device    placed at home '%s': axes %s, scale %g, workspace +-(%g, %g, %g) mm, "
      "centre (%.1f, %.1f, %.1f) mm, skin below it at (%.1f, %.1f, %.1f)",
      g.home_site().c_str(), g.axes().c_str(), g.scale(),
      g.workspace_half_mm_size() == 3 ? g.workspace_half_mm(0) : 0.0,
      g.workspace_half_mm_size() == 3 ? g.workspace_half_mm(1) : 0.0,
      g.workspace_half_mm_size() == 3 ? g.workspace_half_mm(2) : 0.0, g.home().x(), g.home().y(),
      g.home().z(), g.home_skin().x(), g.home_skin().y(), g.home_skin().z());
  if (r.have_stats && r.stats.recentres() > 0)
    std::printf("; re-centred %llu times, centre now (%.1f, %.1f, %.1f)",
                static_cast<unsigned long long>(r.stats.recentres()),
                r.stats.registration_home().x(), r.stats.registration_home().y(),
                r.stats.registration_home().z());
  std::printf("\n");
}

// The force limits the server applies, what the device declares, and the safety chain's state.
void print_limits(const Report& r) {
  if (!r.have_scene) return;
  if (!r.scene.has_limits()) {
    std::printf("  limits    none (%s)\n", r.scene.device().c_str());
    return;
  }
  const v1::ForceLimits& l = r.scene.limits();
  std::printf("  limits    %s: %.2f N", l.profile().c_str(), l.max_force_n());
  if (r.have_stats && r.stats.declared_max_force_n() > 0) {
    std::printf(" (the device declares %.2f N", r.stats.declared_max_force_n());
    if (r.stats.declared_max_stiffness_n_per_mm() > 0)
      std::printf(", %.2f N/mm", r.stats.declared_max_stiffness_n_per_mm());
    if (r.stats.declared_damping_n_s_per_mm() > 0)
      std::printf(", %.3f N s/mm", r.stats.declared_damping_n_s_per_mm());
    std::printf(")");
  }
  std::printf(
      ", %.2f N/mm, step <= %.2f N per tick", l.max_stiffness_n_per_mm(),
      r.scene.tick_rate_hz() > 0 ? l.max_force_rate_n_per_s() / r.scene.tick_rate_hz() : 0.0);
  if (l.coupling_stiffness_n_per_mm() > 0)
    std::printf(", virtual coupling %.2f N/mm and %.4f N s/mm", l.coupling_stiffness_n_per_mm(),
                l.coupling_damping_n_s_per_mm());
  if (l.engage_threshold_n() > 0)
    std::printf(", engages below %.2f N over %.1f s", l.engage_threshold_n(), l.engage_ramp_s());
  if (l.max_damping_n_s_per_mm() > 0)
    std::printf(", passivity controller up to %.3f N s/mm", l.max_damping_n_s_per_mm());
  if (r.have_stats)
    std::printf("; engagement gain now %.2f; passivity controller damped %llu ticks, %.3f mJ",
                r.stats.engage_gain(), static_cast<unsigned long long>(r.stats.passivity_ticks()),
                r.stats.passivity_dissipated_mj());
  std::printf("\n");
}

// What arrived: frames, gaps, latency, silences and the volume's chunks.
void print_stream(const Report& r, const ProbeFigures& s) {
  std::printf(
      "  frames    %llu in %.3f s: %.1f frames/s, delivered %.4f (%llu gaps, %llu frames "
      "missing, largest gap %llu), %llu with contact, %llu zeroed by faults\n",
      static_cast<unsigned long long>(r.frames), s.span_s, s.fps, s.delivered,
      static_cast<unsigned long long>(r.gaps), static_cast<unsigned long long>(r.gap_frames),
      static_cast<unsigned long long>(r.max_gap), static_cast<unsigned long long>(r.contact_frames),
      static_cast<unsigned long long>(r.fault_frames));
  if (s.latency_ok)
    std::printf("  latency   p50 %.1f us, p90 %.1f us, p99 %.1f us, p99.9 %.1f us, max %.1f us\n",
                s.p50, s.p90, s.p99, s.p999, s.lmax);
  else
    std::printf("  latency   n/a (not on the server's host, or no frames)\n");
  std::printf("  arrivals  longest silence %.1f ms, %llu silences over 50 ms\n",
              static_cast<double>(r.max_interval_ns) * 1e-6,
              static_cast<unsigned long long>(r.intervals_over_50ms));
  if (r.volume_chunks)
    std::printf("  volume    %llu chunks, %llu bytes\n",
                static_cast<unsigned long long>(r.volume_chunks),
                static_cast<unsigned long long>(r.volume_bytes));
}

// One histogram over the loop's buckets (jitter_bucket_upper_us; the last one: beyond them).
void print_buckets(const v1::Stats& s,
                   const google::protobuf::RepeatedField<std::uint64_t>& counts) {
  for (int b = 0; b < counts.size(); ++b) {
    if (b < s.jitter_bucket_upper_us_size())
      std::printf(" <%gus:%llu", s.jitter_bucket_upper_us(b),
                  static_cast<unsigned long long>(counts[b]));
    else
      std::printf(" more:%llu", static_cast<unsigned long long>(counts[b]));
  }
  std::printf("\n");
}

// The server's own figures: its rate, the device and its link, tuning, maps and the wake-ups.
void print_server(const v1::Stats& s) {
  std::printf(
      "  server    %.1f Hz (target %.6g), %llu ticks, %llu overruns, %llu faults, "
      "jitter max %.1f us, tick mean %.2f us, %u clients, %s\n",
      s.rate_hz(), s.target_rate_hz(), static_cast<unsigned long long>(s.ticks()),
      static_cast<unsigned long long>(s.overruns()), static_cast<unsigned long long>(s.faults()),
      s.jitter_max_us(), s.tick_mean_us(), s.clients(),
      s.realtime() ? "real time" : "not real time");
  // the device as palpd sees it (e.g. a Falcon: homing, what to do), and its link
  std::printf("  status    device %s%s%s", device_state_text(s.device_state()),
              s.device_message().empty() ? "" : ": ", s.device_message().c_str());
  if (s.device_exchanges() > 0)
    std::printf(
        "; link %llu exchanges, %llu corrupt and %llu short frames, %llu lost replies, "
        "%llu commands force-limited",
        static_cast<unsigned long long>(s.device_exchanges()),
        static_cast<unsigned long long>(s.device_corrupt_frames()),
        static_cast<unsigned long long>(s.device_short_frames()),
        static_cast<unsigned long long>(s.device_lost_replies()),
        static_cast<unsigned long long>(s.device_force_limited()));
  std::printf("\n");
  if (!s.tuning().empty() || !s.tuning_note().empty())
    std::printf("  tuning    %s%s%s\n", s.tuning().empty() ? "defaults" : s.tuning().c_str(),
                s.tuning_note().empty() ? "" : ": ", s.tuning_note().c_str());
  if (!s.maps().empty()) std::printf("  maps      %s\n", s.maps().c_str());
  std::printf("  jitter   ");
  print_buckets(s, s.jitter_counts());
  if (!s.wake_mode().empty()) {
    std::printf(
        "  wake-up   %s, spin window %.0f us; the loop thread uses %.1f %% of a CPU, "
        "%.1f %% spinning; kernel wake-up latency max %.1f us:\n           ",
        s.wake_mode().c_str(), s.spin_window_us(), 100 * s.loop_cpu_fraction(),
        100 * s.spin_cpu_fraction(), s.wake_latency_max_us());
    print_buckets(s, s.wake_latency_counts());
  }
}

// The report for a reader: the outcome, then a line per subject.
void print_report(const std::string& target, const Report& r, const ProbeFigures& s) {
  std::printf("probe %s: %s\n", target.c_str(), r.failure.empty() ? "ok" : r.failure.c_str());
  print_scene(r);
  print_placement(r);
  print_limits(r);
  print_stream(r, s);
  if (r.have_stats) print_server(r.stats);
}

// The last line: the run as JSON.
void print_json(const Report& r, const ProbeFigures& s) {
  std::printf(
      "{\"ok\":%s,\"frames\":%llu,\"frames_per_s\":%s,\"delivered\":%s,\"gaps\":%llu,"
      "\"gap_frames\":%llu,\"max_gap\":%llu,\"max_interval_ms\":%s,\"intervals_over_50ms\":%llu,"
      "\"latency_us\":{\"p50\":%s,\"p90\":%s,\"p99\":%s,\"p999\":%s,\"max\":%s},"
      "\"server_rate_hz\":%s,\"overruns\":%llu,\"faults\":%llu,\"jitter_max_us\":%s,"
      "\"clients\":%u,\"wake\":\"%s\",\"spin_window_us\":%s,\"spin_cpu_fraction\":%s}\n",
      r.failure.empty() && r.frames > 0 ? "true" : "false",
      static_cast<unsigned long long>(r.frames), json_number(s.fps).c_str(),
      json_number(s.delivered).c_str(), static_cast<unsigned long long>(r.gaps),
      static_cast<unsigned long long>(r.gap_frames), static_cast<unsigned long long>(r.max_gap),
      json_number(static_cast<double>(r.max_interval_ns) * 1e-6).c_str(),
      static_cast<unsigned long long>(r.intervals_over_50ms), json_number(s.p50).c_str(),
      json_number(s.p90).c_str(), json_number(s.p99).c_str(), json_number(s.p999).c_str(),
      json_number(s.lmax).c_str(), json_number(r.have_stats ? r.stats.rate_hz() : NAN).c_str(),
      static_cast<unsigned long long>(r.stats.overruns()),
      static_cast<unsigned long long>(r.stats.faults()),
      json_number(r.have_stats ? r.stats.jitter_max_us() : NAN).c_str(), r.stats.clients(),
      r.stats.wake_mode().c_str(),
      json_number(r.have_stats ? r.stats.spin_window_us() : NAN).c_str(),
      json_number(r.have_stats ? r.stats.spin_cpu_fraction() : NAN).c_str());
}

}  // namespace

int cmd_probe(const Arguments& argv) {
  if (wants_check_rate(argv)) return cmd_check_rate(argv);
  if (wants_dds(argv)) return cmd_probe_dds(argv);
  const Args args(argv, {"help", "quiet", "contacts", "same-host"},
                  {"duration", "rate", "stall", "volume-max-dim", "role", "token", "name", "tls-ca",
                   "tls-pin", "tls-cert", "tls-key"});
  if (args.has("help")) {
    std::cout << kProbeUsage << kCheckRateHelp << kProbeDdsHelp;
    return 0;
  }
  const ProbeRequest q = probe_request(args);
  const std::unique_ptr<tls::ClientContext> tls = client_tls(args);
  Probe probe(q.host, std::to_string(q.port), q.hello, q.duration, q.stall, tls.get());
  Report r = probe.run();
  const ProbeFigures s = summarize(r, q.rate, probe.loopback() || q.same_host);
  if (!q.quiet) print_report(q.target, r, s);
  print_json(r, s);
  if (!r.failure.empty()) {
    std::fprintf(stderr, "palp: error: probe: %s\n", r.failure.c_str());
    return 1;
  }
  if (r.frames == 0) {
    std::fprintf(stderr, "palp: error: probe: no frames\n");
    return 1;
  }
  return 0;
}

}  // namespace palp::cli
