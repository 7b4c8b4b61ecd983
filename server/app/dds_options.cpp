#include "app/dds_options.hpp"

#include <unistd.h>

#include <cstdio>

#include "base/errors.hpp"
#include "dds_common.hpp"

namespace palp::app {

const char* const kDdsOptionsHelp =
    R"(DDS (Cyclone DDS; any number of stations, ROS 2 tools; docs/dds.md):
  --dds [DOMAIN]          publish on DDS domain DOMAIN (0..232, default 0): frames, the tool pose
                          and wrench (ROS 2 types), scene, stats, render volume; off without it.
                          CYCLONEDDS_URI configures the network (interfaces, peers, security);
                          config file: dds = true and dds-domain = DOMAIN
  --dds-domain DOMAIN     the same as --dds DOMAIN
  --rig NAME              this rig's name on the domain: topics rt/palp/NAME/... (the host name,
                          or palp; letters, digits, '_')
  --dds-rate HZ           frames per second of loop time on the frame, pose and wrench topics
                          (0 = every tick; default 0)
  --dds-batch-ms MS       also publish rt/palp/NAME/frame_batch: the frames of MS ms of loop time
                          per sample, for subscribers that want every tick without waking for
                          each (palp probe --dds --batch); 0 = off; 1..100, default 10
  --dds-volume-max-dim N  render volume on DDS: at most N voxels per axis (128; 0 = none)
  --dds-control           read device poses from rt/palp/NAME/device_pose (needs --token; each
                          sample must carry it, in clear text: refused with --tls-cert)
)";

std::vector<std::string> with_dds_flags(std::vector<std::string> flags) {
  flags.insert(flags.end(), {"dds", "dds-control"});
  return flags;
}

std::vector<std::string> with_dds_options(std::vector<std::string> valued) {
  valued.insert(valued.end(),
                {"dds-domain", "rig", "dds-rate", "dds-volume-max-dim", "dds-batch-ms"});
  return valued;
}

std::unique_ptr<interop::DdsConfig> dds_config_from(const cli::Args& args, double loop_rate_hz) {
  if (!args.has("dds")) {
    for (const char* key :
         {"dds-domain", "rig", "dds-rate", "dds-volume-max-dim", "dds-batch-ms", "dds-control"})
      if (args.has(key)) throw UsageError(std::string("--") + key + " needs --dds");
    return nullptr;
  }
  auto config = std::make_unique<interop::DdsConfig>();
  config->domain = dds::parse_domain(args.get("dds-domain").value_or("0"));
  config->rig = args.get("rig").value_or(dds::default_rig());
  dds::check_rig(config->rig);
  config->rate_hz = args.number("dds-rate", 0.0);
  if (!(config->rate_hz >= 0.0 && config->rate_hz <= 100000.0))
    throw UsageError("--dds-rate must be in [0, 100000] Hz");
  if (config->rate_hz >= loop_rate_hz) config->rate_hz = 0;  // every tick
  config->batch_ms = args.number("dds-batch-ms", 10.0);
  if (!(config->batch_ms == 0 || (config->batch_ms >= 1 && config->batch_ms <= 100)))
    throw UsageError("--dds-batch-ms must be 0 (off) or in 1..100 ms");
  const double dim = args.number("dds-volume-max-dim", 128);
  if (!(dim >= 0 && dim <= 1024) || dim != static_cast<int>(dim))
    throw UsageError("--dds-volume-max-dim must be an integer in 0..1024");
  config->volume_max_dim = static_cast<std::uint32_t>(dim);
  config->control = args.has("dds-control");
  config->token = args.get("token").value_or("");
  if (config->control && config->token.empty())
    throw UsageError(
        "--dds-control needs --token: anyone on the DDS domain can publish device poses, each "
        "must carry the token");
  if (config->control && (args.has("tls-cert") || args.has("tls-client-ca")))
    throw UsageError(
        "--dds-control with TLS (--tls-cert, --tls-client-ca) is refused: each DDS device pose "
        "carries the token in clear text to anyone on the domain, without the client "
        "certificate palp.v1 asks for; drive the device over palp.v1 (docs/security.md)");
  return config;
}

std::shared_ptr<interop::DdsPublisher> dds_beside(const cli::Args& args,
                                                  const net::SceneDescription& scene,
                                                  rt::HapticLoop& loop, net::ControlTarget& control,
                                                  net::Server& server, const std::string& tool,
                                                  bool quiet) {
  auto config = dds_config_from(args, loop.config().rate_hz);
  if (!config) return nullptr;
  config->report = !quiet;
  char host[256] = {};
  gethostname(host, sizeof host - 1);
  auto publisher =
      std::make_shared<interop::DdsPublisher>(*config, scene, loop, &control, host, tool);
  server.add_snapshot_tap([publisher](const rt::Snapshot& s) { publisher->offer(s); },
                          config->rate_hz);
  publisher->start();
  if (!quiet) {
    std::printf(
        "palpd: DDS domain %u, rig %s: "
        "rt/palp/%s/{frames,frames_contacts%s,tool_pose,wrench,scene,stats%s}"
        "%s at %s\n",
        config->domain, config->rig.c_str(), config->rig.c_str(),
        config->batch_ms > 0 ? ",frame_batch" : "", config->volume_max_dim ? ",volume" : "",
        config->control ? ", reading device_pose" : "",
        config->rate_hz > 0 ? (std::to_string(config->rate_hz) + " Hz").c_str() : "every tick");
    std::fflush(stdout);
  }
  return publisher;
}

}  // namespace palp::app
