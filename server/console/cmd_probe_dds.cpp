// palp probe --dds [DOMAIN] [--rig NAME]: one rig's DDS topics as a subscriber gets them: frames
// per second, the delivered fraction (frame_index gaps: frames the publisher numbered and this
// reader never got), latency from each frame's stamp (CLOCK_REALTIME at the tick's deadline, so
// across hosts only as good as their clock sync), the scene and palpd's stats.
// palp probe --dds --list: the rigs announced on the domain. The last line is JSON.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "base/errors.hpp"
#include "console/json_number.hpp"
#include "console/probe_dds.hpp"
#include "dds_subscriber.hpp"
#include "palp.pb.h"

namespace palp::cli {

const char* const kProbeDdsHelp = R"(
       palp probe --dds [DOMAIN] [--rig NAME] [options]
       palp probe --dds [DOMAIN] --list

Over DDS (palpd --dds; docs/dds.md): subscribes to a rig's topics and prints frames/s, the
delivered fraction, latency from the frames' stamps, the scene and palpd's stats.
  --dds [DOMAIN]          the DDS domain (default 0); CYCLONEDDS_URI configures the network
  --rig NAME              the rig (default: this host's name, as palpd's default)
  --list                  list the rigs announced on the domain (listens --duration, default 2)
  --contacts              read frames_contacts (every frame with its contacts) instead of frames
  --batch                 read frame_batch (palpd --dds-batch-ms: every frame, a batch of them
                          per sample, one wake-up per batch) instead of frames
  --ros                   also count the ROS 2 topics (tool_pose, wrench)
  --volume                also receive the render volume (chunks and bytes)
  --depth N               frames (batches with --batch) the reader keeps between two takes (256)
  --warmup S              count nothing for the first S seconds (joining many subscribers at
                          once), then listen --duration seconds (0)
  --take-ms MS            take what arrived every MS ms instead of waking for each sample
                          (0 = wake for each; a display's way: fewer wake-ups, frames batched)
  --duration, --stall and -q as above
)";

bool wants_dds(const Arguments& argv) {
  return std::any_of(argv.begin(), argv.end(), [](const std::string& a) {
    return a == "--dds" || a.rfind("--dds=", 0) == 0;
  });
}

namespace {

double percentile_floor_rank(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  const std::size_t i =
      std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(i), v.end());
  return v[i];
}

int list(std::uint32_t domain, double duration, bool quiet) {
  const std::vector<dds::RigSeen> rigs = dds::list_rigs(domain, duration);
  if (!quiet) {
    std::printf("probe --dds %u --list: %zu rig%s\n", domain, rigs.size(),
                rigs.size() == 1 ? "" : "s");
    for (const dds::RigSeen& r : rigs)
      std::printf("  %-20s %s host %s pid %u, %s, tool %s, device %s, %.6g Hz%s\n", r.rig.c_str(),
                  r.alive ? "live" : "gone", r.host.c_str(), r.pid, r.scene.c_str(), r.tool.c_str(),
                  r.device.c_str(), r.rate_hz, r.control ? ", control" : "");
  }
  std::string json = "{\"domain\":" + std::to_string(domain) + ",\"rigs\":[";
  for (std::size_t i = 0; i < rigs.size(); ++i) {
    const dds::RigSeen& r = rigs[i];
    if (i) json += ",";
    json += "{\"rig\":\"" + r.rig + "\",\"alive\":" + (r.alive ? "true" : "false") +
            ",\"host\":\"" + r.host + "\",\"pid\":" + std::to_string(r.pid) +
            ",\"rate_hz\":" + json_number(r.rate_hz) + "}";
  }
  std::printf("%s]}\n", json.c_str());
  return 0;
}

// What the command line asks of one probe --dds run (--list aside).
struct DdsRequest {
  std::uint32_t domain = 0;
  bool quiet = false, list = false;
  double duration = 5.0, stall = 1.0, depth = 256, take_ms = 0, warmup = 0;
};

// The probe --dds options read and checked.
DdsRequest dds_request(const Args& args) {
  if (!args.positional().empty())
    throw UsageError("probe --dds takes no HOST:PORT, got '" + args.positional()[0] + "'");
  DdsRequest q;
  q.domain = dds::parse_domain(args.get("dds-domain").value_or("0"));
  q.quiet = args.has("quiet");
  q.list = args.has("list");
  q.duration = args.number("duration", q.list ? 2.0 : 5.0);
  q.stall = args.number("stall", 1.0);
  q.depth = args.number("depth", 256);
  if (!(q.duration > 0)) throw UsageError("--duration must be positive");
  if (!(q.stall > 0)) throw UsageError("--stall must be positive");
  if (!(q.depth >= 1 && q.depth <= 100000)) throw UsageError("--depth must be in 1..100000");
  q.take_ms = args.number("take-ms", 0);
  q.warmup = args.number("warmup", 0);
  if (!(q.warmup >= 0 && q.warmup <= 3600)) throw UsageError("--warmup must be in 0..3600 s");
  if (!(q.take_ms >= 0 && q.take_ms <= 1000)) throw UsageError("--take-ms must be in 0..1000");
  return q;
}

// The subscriber's options: the rig, which topics, the reader's depth.
dds::SubscriberOptions subscriber_options(const Args& args, const DdsRequest& q) {
  if (args.has("batch") && args.has("contacts"))
    throw UsageError("--batch carries frames without contacts: use one of --batch, --contacts");
  dds::SubscriberOptions o;
  o.domain = q.domain;
  o.rig = args.get("rig").value_or(dds::default_rig());
  o.ros = args.has("ros");
  o.contacts = args.has("contacts");
  o.volume = args.has("volume");
  o.batch = args.has("batch");
  o.frame_depth = static_cast<std::int32_t>(q.depth);
  return o;
}

// What arrived on the rig's topics.
struct DdsTally {
  std::uint64_t frames = 0, first_index = 0, last_index = 0, gaps = 0, poses = 0, wrenches = 0;
  std::uint64_t volume_chunks = 0, volume_bytes = 0, volume_count = 0, fault_frames = 0;
  std::int64_t first_rx = 0, last_rx = 0, max_silence = 0;
  std::uint64_t first_take = 0;  // frames taken at first_rx (a batch): not part of the rate
  std::vector<double> latency_us;
  bool have_scene = false, have_stats = false;
  v1::SceneInfo scene;
  v1::Stats stats;
};

// The subscriber's handlers, each counting into `t`.
dds::Handlers tally_handlers(DdsTally& t) {
  dds::Handlers h;
  h.frame = [&t](const palp_dds_HapticFrame& f, std::int64_t rx) {
    if (t.frames == 0)
      t.first_index = f.frame_index, t.first_rx = rx;
    else if (f.frame_index > t.last_index + 1)
      ++t.gaps;
    if (t.frames > 0) t.max_silence = std::max(t.max_silence, rx - t.last_rx);
    t.last_index = std::max(t.last_index, f.frame_index);
    t.last_rx = rx;
    ++t.frames;
    if (rx == t.first_rx) ++t.first_take;
    if (f.fault) ++t.fault_frames;
    t.latency_us.push_back(static_cast<double>(rx - dds::from_time(f.stamp)) * 1e-3);
  };
  h.pose = [&t](const geometry_msgs_msg_dds__PoseStamped_&, std::int64_t) { ++t.poses; };
  h.wrench = [&t](const geometry_msgs_msg_dds__WrenchStamped_&, std::int64_t) { ++t.wrenches; };
  h.encoded = [&t](const char* leaf, const palp_dds_Encoded& e) {
    const std::string which = leaf;
    if (which == dds::kScene)
      t.have_scene = t.scene.ParseFromArray(e.payload._buffer, static_cast<int>(e.payload._length));
    else if (which == dds::kStats)
      t.have_stats = t.stats.ParseFromArray(e.payload._buffer, static_cast<int>(e.payload._length));
    else if (which == dds::kVolume)
      ++t.volume_chunks, t.volume_bytes += e.payload._length, t.volume_count = e.count;
  };
  return h;
}

// The warm-up's frames taken and forgotten (the scene, stats and volume kept).
void skip_warmup(dds::RigSubscriber& sub, const dds::Handlers& h, double warmup) {
  const std::int64_t until = dds::realtime_ns() + static_cast<std::int64_t>(warmup * 1e9);
  dds::Handlers skip;
  skip.encoded = h.encoded;
  while (dds::realtime_ns() < until)
    if (sub.wait(0.05)) sub.take(skip);
}

// Listens for q.duration seconds; the failure, or "" when frames kept coming.
std::string listen(dds::RigSubscriber& sub, const dds::Handlers& h, const DdsTally& t,
                   const DdsRequest& q, const std::string& rig) {
  std::string failure;
  const std::int64_t start = dds::realtime_ns();
  const std::int64_t end = start + static_cast<std::int64_t>(q.duration * 1e9);
  while (true) {
    const std::int64_t now = dds::realtime_ns();
    if (now >= end) break;
    if (q.take_ms > 0) {
      std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(q.take_ms));
      sub.take(h);
    } else if (sub.wait(std::min(0.1, static_cast<double>(end - now) * 1e-9))) {
      sub.take(h);
    }
    const std::int64_t since =
        t.frames ? dds::realtime_ns() - t.last_rx : dds::realtime_ns() - start;
    if (since > static_cast<std::int64_t>((t.frames ? q.stall : std::max(q.stall, 3.0)) * 1e9)) {
      failure = t.frames ? "stalled" : "no frames (no palpd publishing rig " + rig + "?)";
      break;
    }
  }
  sub.take(h);
  if (t.frames == 0 && failure.empty())
    failure = "no frames (no palpd publishing rig " + rig + "?)";
  return failure;
}

// The run's figures: frames/s, the delivered fraction, latency percentiles (NaN without frames).
struct DdsFigures {
  double fps = 0.0, delivered = 0.0;
  double p50 = NAN, p90 = NAN, p99 = NAN, p999 = NAN, lmax = NAN;
};

// The figures of what `t` counted.
DdsFigures summarize(const DdsTally& t) {
  DdsFigures s;
  const double span_s = static_cast<double>(t.last_rx - t.first_rx) * 1e-9;
  s.fps = t.frames > t.first_take && span_s > 0
              ? static_cast<double>(t.frames - t.first_take) / span_s
              : 0.0;
  const double expected = t.frames ? static_cast<double>(t.last_index - t.first_index + 1) : 0.0;
  s.delivered = expected > 0 ? static_cast<double>(t.frames) / expected : 0.0;
  s.p50 = percentile_floor_rank(t.latency_us, 0.5);
  s.p90 = percentile_floor_rank(t.latency_us, 0.9);
  s.p99 = percentile_floor_rank(t.latency_us, 0.99);
  s.p999 = percentile_floor_rank(t.latency_us, 0.999);
  s.lmax = t.latency_us.empty() ? NAN : *std::max_element(t.latency_us.begin(), t.latency_us.end());
  return s;
}

// The report for a reader: the outcome, then a line per subject.
void print_report(const DdsRequest& q, const dds::SubscriberOptions& o,
                  const dds::RigSubscriber& sub, const DdsTally& t, const DdsFigures& s,
                  const std::string& failure) {
  std::printf("probe --dds %u rig %s: %s\n", q.domain, o.rig.c_str(),
              failure.empty() ? "ok" : failure.c_str());
  if (t.have_scene)
    std::printf("  scene     %s, tool %s, device %s, %.6g Hz\n", t.scene.source().c_str(),
                t.scene.tool().name().c_str(), t.scene.device().c_str(), t.scene.tick_rate_hz());
  std::printf("  frames    %llu at %.1f/s, delivered %.4f (%llu gaps), %llu with a fault%s\n",
              static_cast<unsigned long long>(t.frames), s.fps, s.delivered,
              static_cast<unsigned long long>(t.gaps),
              static_cast<unsigned long long>(t.fault_frames),
              o.batch ? (", " + std::to_string(sub.batches()) + " batches").c_str() : "");
  std::printf(
      "  latency   p50 %.1f us, p90 %.1f us, p99 %.1f us, p99.9 %.1f us, max %.1f us "
      "(from the stamp, CLOCK_REALTIME)\n",
      s.p50, s.p90, s.p99, s.p999, s.lmax);
  std::printf("  arrivals  longest silence %.1f ms\n", static_cast<double>(t.max_silence) * 1e-6);
  if (o.ros)
    std::printf("  ros 2     %llu tool_pose, %llu wrench\n",
                static_cast<unsigned long long>(t.poses),
                static_cast<unsigned long long>(t.wrenches));
  if (o.volume)
    std::printf("  volume    %llu of %llu chunks, %llu bytes\n",
                static_cast<unsigned long long>(t.volume_chunks),
                static_cast<unsigned long long>(t.volume_count),
                static_cast<unsigned long long>(t.volume_bytes));
  if (t.have_stats)
    std::printf(
        "  server    %.1f Hz, %llu ticks, %llu overruns, %llu faults, jitter max "
        "%.1f us, %u DDS subscribers, %llu published, %llu dropped before publishing\n",
        t.stats.rate_hz(), static_cast<unsigned long long>(t.stats.ticks()),
        static_cast<unsigned long long>(t.stats.overruns()),
        static_cast<unsigned long long>(t.stats.faults()), t.stats.jitter_max_us(),
        t.stats.clients(), static_cast<unsigned long long>(t.stats.client_frames_sent()),
        static_cast<unsigned long long>(t.stats.client_frames_dropped()));
}

// The last line: the run as JSON, with the keys palp probe HOST:PORT uses where they mean the
// same (tests/bench reads both).
void print_json(const DdsRequest& q, const dds::SubscriberOptions& o, const dds::RigSubscriber& sub,
                const DdsTally& t, const DdsFigures& s, const std::string& failure) {
  std::printf(
      "{\"ok\":%s,\"domain\":%u,\"rig\":\"%s\",\"frames\":%llu,\"frames_per_s\":%s,"
      "\"delivered\":%s,\"gaps\":%llu,\"max_interval_ms\":%s,"
      "\"latency_us\":{\"p50\":%s,\"p90\":%s,\"p99\":%s,\"p999\":%s,\"max\":%s},"
      "\"scene\":%s,\"stats\":%s,\"tool_pose\":%llu,\"wrench\":%llu,\"volume_chunks\":%llu,"
      "\"server_rate_hz\":%s,\"overruns\":%s,\"subscribers\":%s,\"batches\":%llu}\n",
      failure.empty() && t.frames > 0 ? "true" : "false", q.domain, o.rig.c_str(),
      static_cast<unsigned long long>(t.frames), json_number(s.fps).c_str(),
      json_number(s.delivered).c_str(), static_cast<unsigned long long>(t.gaps),
      json_number(static_cast<double>(t.max_silence) * 1e-6).c_str(), json_number(s.p50).c_str(),
      json_number(s.p90).c_str(), json_number(s.p99).c_str(), json_number(s.p999).c_str(),
      json_number(s.lmax).c_str(), t.have_scene ? "true" : "false", t.have_stats ? "true" : "false",
      static_cast<unsigned long long>(t.poses), static_cast<unsigned long long>(t.wrenches),
      static_cast<unsigned long long>(t.volume_chunks),
      t.have_stats ? json_number(t.stats.rate_hz()).c_str() : "null",
      t.have_stats ? std::to_string(t.stats.overruns()).c_str() : "null",
      t.have_stats ? std::to_string(t.stats.clients()).c_str() : "null",
      static_cast<unsigned long long>(sub.batches()));
}

}  // namespace

int cmd_probe_dds(const Arguments& argv_in) {
  const Arguments argv = dds::split_dds_domain(argv_in);
  const Args args(argv, {"help", "quiet", "dds", "list", "ros", "volume", "contacts", "batch"},
                  {"dds-domain", "rig", "duration", "stall", "depth", "take-ms", "warmup"});
  if (args.has("help")) {
    std::cout << "usage: " << (kProbeDdsHelp + 8);  // without the leading "\n       "
    return 0;
  }
  const DdsRequest q = dds_request(args);
  if (q.list) return list(q.domain, q.duration, q.quiet);
  const dds::SubscriberOptions o = subscriber_options(args, q);
  dds::RigSubscriber sub(o);

  DdsTally t;
  t.latency_us.reserve(static_cast<std::size_t>(std::min(q.duration * 20000.0, 2e6)));
  const dds::Handlers h = tally_handlers(t);
  if (q.warmup > 0) skip_warmup(sub, h, q.warmup);
  const std::string failure = listen(sub, h, t, q, o.rig);
  const DdsFigures s = summarize(t);
  if (!q.quiet) print_report(q, o, sub, t, s, failure);
  print_json(q, o, sub, t, s, failure);
  if (!failure.empty()) {
    std::fprintf(stderr, "palp: error: probe --dds: %s\n", failure.c_str());
    return 1;
  }
  return 0;
}

}  // namespace palp::cli
